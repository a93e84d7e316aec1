"""Proposers plug into the driver; segment errors are journalled; old journals are refused."""
from __future__ import annotations

import sqlite3

import numpy as np
import pytest

from belief import Grid, Proposal, Proposer, identify
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
