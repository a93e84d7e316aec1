"""The objective contract: BatchResult validation, the status vocabulary, evaluate_row, the Protocol."""
from __future__ import annotations

import numpy as np
import pytest

from physics.errors import ParameterError, PhysicsError, TrajectoryFormatError
from physics.objective import STATUSES, BatchResult, Objective, evaluate_row
from physics.push import PushObjective, generate_push_data

NAN = float("nan")


def _result(**change):
    fields = dict(errors=np.array([1.0, NAN]), status=("ok", "diverged"), seconds=np.array([0.1, 0.2]),
                  messages=("", "PhysicsError: boom"), parts=np.array([[0.25, 0.75], [NAN, NAN]]))
    fields.update(change)
    return BatchResult(**fields)


def test_batch_result_rows_length_and_iteration():
    res = _result()
    assert STATUSES == ("ok", "diverged", "failed")
    assert len(res) == 2 and res.n_segments == 2
    rows = list(res)
    assert rows[0] == (1.0, "ok") and rows[1][1] == "diverged" and np.isnan(rows[1][0])
    with pytest.raises(AttributeError):
        res.errors = np.zeros(2)                   # frozen
    again = BatchResult.from_rows([(1.0, "ok", 0.1, "", np.array([0.25, 0.75])),
                                   (NAN, "diverged", 0.2, "PhysicsError: boom", np.full(2, NAN))], 2)
    np.testing.assert_array_equal(again.parts, res.parts)
    assert again.status == res.status and again.messages == res.messages


@pytest.mark.parametrize("change, match", [
    (dict(errors=np.array([1.0])), r"one entry per status \(n = 2\)"),
    (dict(seconds=np.array([0.1, 0.2, 0.3])), "seconds"),
    (dict(messages=("",)), "1 messages"),
    (dict(parts=np.array([0.25, 0.75])), r"parts must have shape \(n, S\)"),
    (dict(parts=np.ones((3, 2))), r"parts must have shape \(n, S\) = \(2, S\)"),
    (dict(status=("ok", "error")), r"status must be one of .*'error'"),
    (dict(errors=np.array([NAN, NAN]), parts=np.full((2, 2), NAN)), "'ok' row has a NaN"),
    (dict(errors=np.array([1.0, 2.0])), "must have NaN errors and NaN parts"),
    (dict(parts=np.array([[0.25, 0.75], [1.0, NAN]])), "must have NaN errors and NaN parts"),
    (dict(parts=np.array([[0.5, 0.75], [NAN, NAN]])), r"errors must equal parts.sum\(1\)"),
])
def test_batch_result_validation(change, match):
    with pytest.raises(ParameterError, match=match):
        _result(**change)


class _Fake:
    """An objective whose evaluate_parts does what it is told."""

    segments = ("a", "b")

    def __init__(self, outcome):
        self.outcome = outcome

    def evaluate_parts(self, theta):
        if isinstance(self.outcome, Exception):
            raise self.outcome
        return self.outcome


@pytest.mark.parametrize("outcome, status, message", [
    (np.array([1.0, 2.0]), "ok", ""),
    (PhysicsError("exploded"), "diverged", "exploded"),
    (TrajectoryFormatError("no rest_length"), "failed", "TrajectoryFormatError: no rest_length"),
    (np.array([1.0, np.inf]), "failed", "not one finite value per segment"),
    (np.array([1.0]), "failed", "for 2 segments"),
])
def test_evaluate_row_maps_outcomes_to_the_status_vocabulary(outcome, status, message):
    error, got, seconds, why, parts = evaluate_row(_Fake(outcome), np.zeros(2))
    assert got == status and message in why and seconds >= 0 and parts.shape == (2,)
    if status == "ok":
        assert error == 3.0 and why == ""
    else:
        assert np.isnan(error) and np.isnan(parts).all()
    BatchResult.from_rows([(error, got, seconds, why, parts)], 2)     # every row makes a valid result


def test_evaluate_row_lets_bugs_through():
    with pytest.raises(ZeroDivisionError):
        evaluate_row(_Fake(ZeroDivisionError("bug")), np.zeros(2))


def test_push_error_satisfies_the_protocol():
    J, S = generate_push_data([1.0, 0.4], n=4, seed=0)
    assert isinstance(PushObjective(J, S), Objective)
    assert not isinstance(_Fake(np.zeros(2)), Objective)


def test_batch_result_is_still_importable_from_physics_error():
    from physics import BatchResult as exported
    from physics.trajectory_objective import BatchResult as old_home
    assert exported is old_home is BatchResult
