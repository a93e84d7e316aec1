"""Every candidate set (belief.grid.CandidateSet) passes the same checks.

A new kind of candidate set is one line in IMPLEMENTATIONS (a factory returning an instance).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from belief.errors import GridError
from belief.grid import CandidateSet, Grid, SobolCandidates, candidates_from_config

IMPLEMENTATIONS = [
    pytest.param(lambda: Grid([[0.0, 1.0], [-2.0, 2.0]], points_per_dim=5), id="Grid-2d"),
    pytest.param(lambda: Grid([[0.0, 1.0]], points_per_dim=11), id="Grid-1d"),
    pytest.param(lambda: Grid(np.tile([-1.0, 1.0], (3, 1)), points_per_dim=(3, 4, 2)), id="Grid-per-axis"),
    pytest.param(lambda: SobolCandidates([[0.0, 1.0], [-2.0, 2.0]], n=64, seed=0), id="SobolCandidates-2d"),
    pytest.param(lambda: SobolCandidates(np.tile([0.0, 1.0], (15, 1)), n=200, seed=3), id="SobolCandidates-15d"),
    pytest.param(lambda: SobolCandidates([[0.0, 1.0], [0.0, 1.0]], n=16, seed=1, include=[[0.5, 0.5], [1.0, 0.0]]),
                 id="SobolCandidates-include"),
]


@pytest.fixture(scope="module", params=IMPLEMENTATIONS)
def cells(request) -> CandidateSet:
    return request.param()


def test_every_candidate_set_of_belief_is_checked() -> None:
    kinds = {cls for cls in CandidateSet.__subclasses__() if cls.__module__.startswith("belief.")}
    assert kinds <= {Grid, SobolCandidates}, "add the new candidate set to IMPLEMENTATIONS"


def test_cells_lie_in_the_box(cells: CandidateSet) -> None:
    assert isinstance(cells, CandidateSet)
    pts = cells.points
    assert pts.shape == (cells.size, cells.dim) == (len(cells), cells.bounds.shape[0]) and cells.size >= 1
    assert not pts.flags.writeable and np.isfinite(pts).all()
    assert (pts >= cells.bounds[:, 0]).all() and (pts <= cells.bounds[:, 1]).all()
    assert cells.latent_names == tuple(f"z{i}" for i in range(cells.dim))


def test_nearest_finds_each_cell_and_the_closest_cell(cells: CandidateSet) -> None:
    np.testing.assert_array_equal(cells.nearest(cells.points), np.arange(cells.size))
    assert cells.nearest(cells.points[0]).shape == (1,)
    z = cells.bounds[:, 0] + np.random.default_rng(0).random((25, cells.dim)) * np.ptp(cells.bounds, axis=1)
    got = cells.nearest(z)
    assert got.shape == (25,) and ((got >= 0) & (got < cells.size)).all()
    d2 = ((z[:, None, :] - cells.points[None]) ** 2).sum(axis=2)
    np.testing.assert_allclose(d2[np.arange(25), got], d2.min(axis=1), rtol=1e-12, atol=1e-15)
    with pytest.raises(GridError):
        cells.nearest(np.zeros((2, cells.dim + 1)))


def test_values_become_a_dataarray_over_the_cells(cells: CandidateSet) -> None:
    values = np.arange(cells.size, dtype=float)
    da = cells.to_dataarray(values, name="P")
    assert da.dims == cells.dims and da.size == cells.size and da.name == "P"
    np.testing.assert_array_equal(da.values.ravel(), values)            # flat cell order = C order
    latent = np.stack([da.coords[n].broadcast_like(da).values.ravel() for n in cells.latent_names], axis=1)
    np.testing.assert_array_equal(latent, cells.points)                 # the coordinates are the cells' points
    with pytest.raises(GridError):
        cells.to_dataarray(values[:-1])


def test_config_rebuilds_the_same_cells(cells: CandidateSet) -> None:
    config = json.loads(json.dumps(cells.config()))                   # as a journal or a belief stores it
    for rebuilt in (candidates_from_config(config), type(cells).from_config(config)):
        assert type(rebuilt) is type(cells) and rebuilt.config() == cells.config()
        np.testing.assert_array_equal(rebuilt.points, cells.points)
    with pytest.raises(GridError):
        candidates_from_config({**config, "kind": "no-such-kind"})
