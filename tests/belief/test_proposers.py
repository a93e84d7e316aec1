"""Proposers plug into the driver; segment errors are journalled; old journals are refused."""
from __future__ import annotations

import sqlite3

import numpy as np
import pytest

from belief import BOProposer, Grid, Proposal, Proposer, SobolDesign, identify
from belief.proposers import sobol_design
from belief.errors import JournalError
from embeddings import Identity


class EveryOtherCell:
    """A proposer written outside belief: cells 0, 2, 4, ... in order."""

    def propose(self, batch, history, size, grid):
        done = {r.cell for r in history}
        return Proposal([c for c in range(0, grid.size, 2) if c not in done][:size])

    def config(self):
        return {"kind": "every-other"}


def test_a_custom_proposer_runs_without_editing_the_driver(push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=11)
    prop = EveryOtherCell()
    assert isinstance(prop, Proposer)
    res = identify(obj, dec, grid, budget=8, n_init=3, seed=0, proposer=prop, progress=False, posterior=None)
    assert res.history["cell"].values.tolist() == [0, 2, 4, 6, 8, 10, 12, 14]
    assert res.config["proposer"] == {"kind": "every-other"}


def test_segment_errors_are_journalled_and_survive_a_resume(push_problem, tmp_path) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=11)
    path = tmp_path / "run.sqlite"
    first = identify(obj, dec, grid, budget=7, seed=0, journal=path, progress=False, posterior=None)
    again = identify(obj, dec, grid, budget=9, seed=0, journal=path, progress=False, posterior=None)
    parts = again.history["parts"].values
    assert again.history["segment"].values.tolist() == list(obj.segments)
    np.testing.assert_allclose(parts.sum(axis=1), again.history["error"].values)
    np.testing.assert_array_equal(parts[:7], first.history["parts"].values)
    thetas = again.history["theta"].values
    np.testing.assert_allclose(parts[3], obj.evaluate_parts(thetas[3]))


def test_a_schema_1_journal_is_refused(push_problem, tmp_path) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=11)
    path = tmp_path / "old.sqlite"
    identify(obj, dec, grid, budget=5, seed=0, journal=path, progress=False, posterior=None)
    with sqlite3.connect(path) as con:
        con.execute("UPDATE meta SET value='1' WHERE key='schema'")
    with pytest.raises(JournalError, match="schema 1.*use a new journal path"):
        identify(obj, dec, grid, budget=6, seed=0, journal=path, progress=False, posterior=None)


def test_sobol_design_is_the_initial_design_of_bo(push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=11)
    assert SobolDesign(3).propose(0, [], 5, grid).cells == sobol_design(grid, 5, 3)
    assert BOProposer(3).initial.config() == {"kind": "sobol", "seed": 3}
    bo = identify(obj, dec, grid, budget=5, n_init=5, seed=3, progress=False, posterior=None)
    qmc = identify(obj, dec, grid, budget=9, n_init=5, q=2, seed=3, proposer=SobolDesign(3), progress=False,
                   posterior=None)
    cells = qmc.history["cell"].values.tolist()
    assert cells[:5] == bo.history["cell"].values.tolist()
    assert len(set(cells)) == 9


def test_bo_takes_another_acquisition(push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=11)

    def lowest_free(model, points, available, *, q, prediction=None):
        assert prediction is not None and prediction[0].shape == (points.shape[0],)
        return [int(c) for c in np.flatnonzero(available)[:q]]

    prop = BOProposer(0, acquisition=lowest_free)
    res = identify(obj, dec, grid, budget=7, n_init=5, seed=0, proposer=prop, progress=False, posterior=None)
    first = sorted(res.history["cell"].values[:5].tolist())
    free = [c for c in range(grid.size) if c not in first]
    assert res.history["cell"].values[5:].tolist() == free[:2]
    assert res.config["proposer"]["acquisition"].endswith("lowest_free")


def test_a_warm_start_is_evaluated_first_and_saved_with_the_candidates(push_problem) -> None:
    from belief import SobolCandidates
    from belief.grid import candidates_from_config
    from belief.proposers import WarmStart

    obj, _ = push_problem()
    dec = Identity(obj.space)
    warm = dec.encode(obj.space.nominal)
    grid = SobolCandidates(dec.bounds, n=64, seed=1, include=warm[None])
    np.testing.assert_array_equal(grid.points[0], warm)
    assert grid.size == 65 and candidates_from_config(grid.config()).config() == grid.config()
    prop = BOProposer(0, initial=WarmStart([0], SobolDesign(0)))
    res = identify(obj, dec, grid, budget=8, n_init=4, seed=0, proposer=prop, progress=False, posterior=None)
    cells = res.history["cell"].values.tolist()
    assert cells[0] == 0 and len(set(cells)) == 8
    with pytest.raises(Exception, match="inside the latent box"):
        SobolCandidates(dec.bounds, n=8, seed=1, include=[[5.0] * dec.dim])
