"""Every implementation of the Objective contract (physics.objective) passes the same checks.

A new objective is one line in IMPLEMENTATIONS: a factory returning a :class:`Case` (the
objective, rows θ (n, D) that evaluate "ok", a θ whose evaluation fails or None, and whether E is
a sum of squared residuals). Each check below then runs on it.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pytest

from physics.errors import NoResidualsError, PhysicsError, TensegridError
from physics.objective import STATUSES, BatchResult, FunctionObjective, Objective, evaluate_row
from physics.parameters import ParameterSpace
from physics.push import PushObjective, generate_push_data, push_space


@dataclass(frozen=True)
class Case:
    """objective; thetas (n, D) rows that evaluate "ok"; bad: a θ (D,) whose evaluation is not ok,
    or None; squared: E = Σ_s nansum(r_s²) (the residuals reproduce E); residuals: it has residuals."""

    objective: Objective
    thetas: np.ndarray
    bad: np.ndarray | None
    squared: bool
    residuals: bool = True


def _push() -> Case:
    J, S = generate_push_data([1.0, 0.4], n=6, noise_std=0.05, seed=0)
    obj = PushObjective(J, S, noise_std=0.05, fail_above=1.4, windows=3)
    return Case(obj, np.array([[1.0, 0.4], [0.7, 0.9], [1.3, 0.2]]), np.array([1.45, 0.4]), squared=True)


@lru_cache(maxsize=1)
def _flop():
    from physics import FlopController, simulate

    return simulate(controller=FlopController(heading=0.0), duration=0.3)


def _trajectory(loss: str, horizon: "int | str") -> Case:
    from physics.trajectory_objective import TrajectoryObjective

    space = ParameterSpace.t6()
    obj = TrajectoryObjective(_flop(), loss=loss, horizon=horizon, windows=2, n_workers=0)
    thetas = np.vstack([space.nominal, space.replace(damping=190.0), space.sample(1, seed=3)])
    return Case(obj, thetas, space.replace(stiffnessActive=1e7), squared=loss == "squared")


def _fixed_push() -> Case:
    """The push toy with mu held at 0.4 (physics.fixed): θ = (m,)."""
    from physics.fixed import FixedParameters

    J, S = generate_push_data([1.0, 0.4], n=6, noise_std=0.05, seed=0)
    obj = FixedParameters(PushObjective(J, S, noise_std=0.05, fail_above=1.4, windows=3), {"mu": 0.4})
    return Case(obj, np.array([[1.0], [0.7], [1.3]]), np.array([1.45]), squared=True)


def _fixed_trajectory() -> Case:
    """The T6 error with rod_length and motor_friction held (physics.fixed): θ has the other 13."""
    from physics.fixed import FixedParameters
    from physics.trajectory_objective import TrajectoryObjective

    obj = FixedParameters(TrajectoryObjective(_flop(), windows=2, n_workers=0),
                          {"rod_length": 1.7, "motor_friction": 8.6e-5})
    thetas = np.vstack([obj.space.nominal, obj.space.replace(damping=190.0), obj.space.sample(1, seed=3)])
    return Case(obj, thetas, obj.space.replace(stiffnessActive=1e7), squared=True)


def _bowl(theta: np.ndarray) -> float:
    """(m - 1)² + (μ - 0.4)², and a diverged 'simulation' above m = 1.4."""
    if theta[0] > 1.4:
        raise PhysicsError("the bowl diverged above m = 1.4")
    return float((theta[0] - 1.0) ** 2 + (theta[1] - 0.4) ** 2)


def _function(workers: int) -> Case:
    obj = FunctionObjective(_bowl, push_space(), workers=workers)
    return Case(obj, np.array([[1.0, 0.4], [0.7, 0.9], [1.3, 0.2]]), np.array([1.45, 0.4]), squared=False,
                residuals=False)


IMPLEMENTATIONS = [
    pytest.param(_push, id="PushObjective"),
    pytest.param(lambda: _trajectory("squared", 1), id="TrajectoryObjective-squared"),
    pytest.param(lambda: _trajectory("norm", "rollout"), id="TrajectoryObjective-rollout"),
    pytest.param(lambda: _function(1), id="FunctionObjective"),
    pytest.param(lambda: _function(3), id="FunctionObjective-threads"),
    pytest.param(_fixed_push, id="FixedParameters-push"),
    pytest.param(_fixed_trajectory, id="FixedParameters-T6"),
]


@pytest.fixture(scope="module", params=IMPLEMENTATIONS)
def case(request) -> Case:
    return request.param()


def test_declares_the_contract(case: Case) -> None:
    obj = case.objective
    assert isinstance(obj, Objective)
    assert isinstance(obj.segments, tuple) and obj.segments and len(set(obj.segments)) == len(obj.segments)
    assert all(isinstance(s, str) and s for s in obj.segments)
    assert isinstance(obj.n_observations, int) and obj.n_observations >= 1
    assert obj.noise_var is None or (np.isfinite(obj.noise_var) and obj.noise_var > 0)
    assert isinstance(obj.space, ParameterSpace) and case.thetas.shape[1] == obj.space.dim


def test_parts_sum_to_E(case: Case) -> None:
    obj = case.objective
    for theta in case.thetas:
        parts = obj.evaluate_parts(theta)
        assert parts.shape == (len(obj.segments),) and np.isfinite(parts).all() and (parts >= 0).all()
        value = obj(theta)
        assert isinstance(value, float) and value == pytest.approx(parts.sum(), rel=1e-12)


def test_evaluation_is_deterministic(case: Case) -> None:
    obj = case.objective
    assert np.array_equal(obj.evaluate_parts(case.thetas[0]), obj.evaluate_parts(case.thetas[0]))


def test_evaluate_batch_equals_per_row_evaluate_parts(case: Case) -> None:
    obj = case.objective
    streamed: dict[int, tuple] = {}
    result = obj.evaluate_batch(case.thetas, on_result=lambda k, *row: streamed.setdefault(k, row))
    n, S = case.thetas.shape[0], len(obj.segments)
    assert isinstance(result, BatchResult) and len(result) == n and result.n_segments == S
    assert result.status == ("ok",) * n and result.messages == ("",) * n and (result.seconds >= 0).all()
    want = np.array([obj.evaluate_parts(theta) for theta in case.thetas])
    np.testing.assert_allclose(result.parts, want, rtol=1e-12)
    np.testing.assert_allclose(result.errors, want.sum(axis=1), rtol=1e-12)
    assert sorted(streamed) == list(range(n))                     # once per row, as the result has it
    for k, (error, status, seconds, message, parts) in streamed.items():
        assert (error, status, message) == (result.errors[k], result.status[k], result.messages[k])
        np.testing.assert_array_equal(parts, result.parts[k])


def test_failures_are_statuses_with_a_reason(case: Case) -> None:
    if case.bad is None:
        pytest.skip("no failing θ known for this objective")
    obj = case.objective
    with pytest.raises(TensegridError):
        obj.evaluate_parts(case.bad)
    result = obj.evaluate_batch(np.vstack([case.thetas[0], case.bad]))
    assert set(result.status) <= set(STATUSES) and result.status[0] == "ok" and result.status[1] != "ok"
    assert np.isnan(result.errors[1]) and np.isnan(result.parts[1]).all() and result.messages[1]
    assert evaluate_row(obj, case.bad)[1] == result.status[1]


def test_residuals_follow_the_segments(case: Case) -> None:
    obj = case.objective
    if not case.residuals:
        with pytest.raises(NoResidualsError):
            obj.residuals(case.thetas[0])
        with pytest.raises(NoResidualsError):
            obj.residuals_batch(case.thetas)
        return
    rows = obj.residuals_batch(case.thetas)
    assert len(rows) == len(case.thetas)
    for theta, got in zip(case.thetas, rows):
        want = obj.residuals(theta)
        assert len(want) == len(obj.segments) and all(r.ndim == 2 for r in want)
        assert len({r.shape[1] for r in want}) == 1                 # one m for every segment
        assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(got, want))
        if case.squared:
            assert sum(np.nansum(r ** 2) for r in want) == pytest.approx(obj(theta), rel=1e-10)
    if case.bad is not None:
        assert obj.residuals_batch(np.vstack([case.thetas[0], case.bad]))[1] is None


def test_fingerprint_is_json_and_names_the_segments(case: Case) -> None:
    obj = case.objective
    fp = obj.fingerprint()
    assert json.loads(json.dumps(fp)) == fp and fp == obj.fingerprint()
    assert fp["segments"] == list(obj.segments)
