"""Grid and SobolCandidates share one protocol; shapes, coordinates, nearest cell, validation."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from belief import Grid, GridError, SobolCandidates


def test_regular_grid_points_coords_and_reshape() -> None:
    g = Grid([[0.0, 1.0], [-2.0, 2.0]], points_per_dim=(3, 5))
    assert g.size == 15 and g.dim == 2 and g.dims == ("z0", "z1") and g.points.shape == (15, 2)
    values = np.arange(15.0)
    da = g.to_dataarray(values, name="v")
    assert isinstance(da, xr.DataArray) and da.dims == ("z0", "z1") and da.shape == (3, 5)
    np.testing.assert_allclose(da["z1"].values, np.linspace(-2, 2, 5))
    # C order: the value of flat cell k sits at the coordinates of points[k]
    for k in (0, 7, 14):
        z0, z1 = g.points[k]
        assert float(da.sel(z0=z0, z1=z1)) == values[k]
    np.testing.assert_array_equal(g.nearest(g.points), np.arange(15))
    assert g.nearest(np.array([[0.49, 1.1]]))[0] == np.ravel_multi_index((1, 3), (3, 5))


def test_sobol_candidates_protocol_and_seed() -> None:
    b = np.tile([0.0, 1.0], (15, 1))
    s1, s2, s3 = (SobolCandidates(b, n=500, seed=1), SobolCandidates(b, n=500, seed=1),
                  SobolCandidates(b, n=500, seed=2))
    assert np.array_equal(s1.points, s2.points) and not np.array_equal(s1.points, s3.points)
    assert s1.points.shape == (500, 15) and s1.dims == ("cell",)
    assert np.all(s1.points >= 0) and np.all(s1.points <= 1)
    da = s1.to_dataarray(np.ones(500))
    assert da.dims == ("cell",) and "z14" in da.coords
    np.testing.assert_array_equal(s1.nearest(s1.points[[3, 99]]), [3, 99])


def test_points_are_read_only() -> None:
    g = Grid([[0.0, 1.0]], points_per_dim=4)
    with pytest.raises(ValueError):
        g.points[0, 0] = 3.0


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: Grid([[0.0, 1.0]], points_per_dim=0), "empty grid"),
        (lambda: Grid([[0.0, 1.0]], points_per_dim=1), ">= 2"),
        (lambda: Grid([[1.0, 0.0]]), "lower < upper"),
        (lambda: Grid(np.zeros((2, 3))), r"shape \(d, 2\)"),
        (lambda: Grid(np.tile([0.0, 1.0], (15, 1)), points_per_dim=11), "exceeds MAX_CELLS"),
        (lambda: Grid([[0.0, 1.0]], points_per_dim=2.5), "must be an int"),
        (lambda: SobolCandidates([[0.0, 1.0]], n=0, seed=0), "empty candidate set"),
        (lambda: SobolCandidates([[0.0, 1.0]], n=4, seed=None), "seed must be an integer"),
        (lambda: Grid([[0.0, 1.0]], points_per_dim=3).to_dataarray(np.ones(4)), "one value per cell"),
        (lambda: Grid([[0.0, 1.0]], points_per_dim=3).nearest(np.ones((1, 2))), "nearest expects"),
    ],
)
def test_validation(call, match: str) -> None:
    with pytest.raises(GridError, match=match):
        call()
