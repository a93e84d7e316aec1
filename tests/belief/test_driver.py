"""The driver's one status path: batches through evaluate_batch, one-cell batches through
evaluate_row, the same statuses either way; plain functions reach it wrapped in FunctionObjective."""
from __future__ import annotations

import sqlite3
import threading

import numpy as np
import pytest

from belief import Grid, ObjectiveError, identify
from embeddings import Identity
from physics.errors import ContractError, ControllerError, NoResidualsError, ParameterError
from physics.objective import FunctionObjective, Objective, as_objective
from physics.push import PushObjective

#: with n_init = 5 and q = 1: call 1 is in batch 0 (evaluate_batch), call 6 is batch 2 (one cell, evaluate_row)
FAILING_CALLS = (1, 6)


class _ControllerFailures(PushObjective):
    """The push objective whose evaluations number FAILING_CALLS raise ControllerError, a tensegrid
    error that is not a PhysicsError (a controller refusing its command, not a diverged simulation)."""

    calls = 0

    def evaluate_parts(self, theta):
        type(self).calls += 1
        if type(self).calls - 1 in FAILING_CALLS:
            raise ControllerError("the controller refused the command")
        return super().evaluate_parts(theta)


def _failing_function(obj):
    calls = [0]

    def fn(theta):
        calls[0] += 1
        if calls[0] - 1 in FAILING_CALLS:
            raise ControllerError("the controller refused the command")
        return obj(theta)

    return fn


@pytest.mark.parametrize("plain", [False, True], ids=["objective", "plain-function"])
def test_a_controller_error_is_failed_in_a_batch_and_in_a_one_cell_batch(push_problem, tmp_path, plain) -> None:
    obj, _ = push_problem()
    _ControllerFailures.calls = 0
    objective = _failing_function(obj) if plain else _ControllerFailures(obj.impulses, obj.observed,
                                                                          noise_std=obj.noise_std)
    dec = Identity(obj.space)
    path = tmp_path / "j.sqlite"
    res = identify(objective, dec, Grid.for_decoder(dec, points_per_dim=11), budget=9, n_init=5, q=1, seed=0,
                   journal=path, progress=False, posterior=None)
    h = res.history
    failed = np.flatnonzero(h["status"].values == "failed")
    assert h["batch"].values[failed].tolist() == [0, 2]          # the first batch and a later one-cell batch
    assert all("ControllerError: the controller refused" in m for m in h["message"].values[failed])
    assert np.isnan(h["error"].values[failed]).all() and res.n_evaluations == 9
    with sqlite3.connect(path) as con:             # each row was journalled with its status
        journalled = [row[0] for row in con.execute("SELECT status FROM evaluations ORDER BY batch, cell")]
    assert journalled == h["status"].values.tolist()


def test_rows_missing_from_on_result_are_an_error(push_problem) -> None:
    obj, _ = push_problem()

    class Silent(PushObjective):
        def evaluate_batch(self, thetas, *, on_result=None):
            return super().evaluate_batch(thetas)                  # computes the rows, never reports them

    dec = Identity(obj.space)
    with pytest.raises(ObjectiveError, match=r"did not report rows \[0, 1, 2, 3, 4\] of 5 through on_result"):
        identify(Silent(obj.impulses, obj.observed), dec, Grid.for_decoder(dec, points_per_dim=11), budget=6,
                 seed=0, progress=False)


def test_as_objective_wraps_plain_functions_once_and_keeps_objectives(push_problem) -> None:
    obj, _ = push_problem()
    assert as_objective(obj) is obj and as_objective(obj, obj.space) is obj
    wrapped = as_objective(lambda th: float(th.sum()), obj.space, workers=2)
    assert isinstance(wrapped, FunctionObjective) and isinstance(wrapped, Objective)
    assert as_objective(wrapped) is wrapped and wrapped.segments == ("all",) and wrapped.workers == 2
    with pytest.raises(NoResidualsError, match="gives E\\(θ\\) only"):
        wrapped.residuals(obj.space.nominal)

    class Half:                      # part of the contract: refused, not silently reduced to E
        space = obj.space

        def __call__(self, theta):
            return 0.0

        def evaluate_parts(self, theta):
            return np.zeros(2)

    with pytest.raises(ContractError, match=r"has \['evaluate_parts'\] of the Objective contract but lacks"):
        as_objective(Half())
    with pytest.raises(ParameterError, match="pass space="):
        as_objective(lambda th: 0.0)
    with pytest.raises(ParameterError, match="workers must be an integer >= 1"):
        as_objective(lambda th: 0.0, obj.space, workers=0)


def test_threaded_batches_stream_every_row_once_in_completion_order(push_problem) -> None:
    obj, _ = push_problem()
    reported = threading.Event()

    def fn(theta):
        if theta[0] < 1.0:           # the first rows wait until a later row has been reported
            reported.wait(timeout=5.0)
        return obj(theta)

    def on_result(k, *row) -> None:
        seen.append(k)
        reported.set()

    thetas = np.array([[0.8, 0.4], [0.9, 0.4], [1.2, 0.4], [1.3, 0.4]])
    seen: list[int] = []
    result = FunctionObjective(fn, obj.space, workers=4).evaluate_batch(thetas, on_result=on_result)
    assert sorted(seen) == [0, 1, 2, 3] and seen[0] in (2, 3)
    np.testing.assert_allclose(result.errors, [obj(t) for t in thetas])
    assert result.status == ("ok",) * 4 and result.n_segments == 1
