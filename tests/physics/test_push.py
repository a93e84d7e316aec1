"""The push toy S = J^2 / (2 m^2 mu): ridge invariance, shapes, data generation, objective, validation."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from physics.errors import ParameterError, PhysicsError
from physics.push import PushObjective, generate_push_data, push_space, simulate_push


def test_paper_example_values() -> None:
    # Zhu et al. 2018, Sec. IV-C: Ft = 1, (m, mu) = (1, 0.32) and (0.8, 0.5) both give S = 1.5625
    S = simulate_push(np.array([[1.0, 0.32], [0.8, 0.5]]), [1.0])
    np.testing.assert_allclose(S[:, 0], [1.5625, 1.5625])


@settings(max_examples=50, deadline=None)
@given(m=st.floats(0.5, 1.5), mu=st.floats(0.1, 1.0), scale=st.floats(0.8, 1.2))
def test_ridge_invariance(m: float, mu: float, scale: float) -> None:
    """Same m^2 mu -> same displacement for every impulse; a different m^2 mu -> a different one."""
    J = np.linspace(0.2, 2.0, 5)
    m2 = m * scale
    mu2 = mu * m**2 / m2**2
    np.testing.assert_allclose(simulate_push([m, mu], J), simulate_push([m2, mu2], J), rtol=1e-12)
    if abs(scale - 1) > 1e-3:
        assert not np.allclose(simulate_push([m, mu], J), simulate_push([m2, mu], J))


def test_shapes_and_monotonicity() -> None:
    J = np.array([0.5, 1.0, 2.0])
    S1 = simulate_push([1.0, 0.5], J)
    assert S1.shape == (3,)
    assert np.all(np.diff(S1) > 0)  # more impulse, further
    S2 = simulate_push(np.array([[1.0, 0.5], [1.2, 0.5], [1.0, 0.7]]), J)
    assert S2.shape == (3, 3)
    assert np.all(S2[1] < S2[0]) and np.all(S2[2] < S2[0])  # heavier or rougher, shorter


def test_generate_data_seeded_and_noisy() -> None:
    J1, S1 = generate_push_data([1.0, 0.4], n=6, noise_std=0.05, seed=3)
    J2, S2 = generate_push_data([1.0, 0.4], n=6, noise_std=0.05, seed=3)
    _, S3 = generate_push_data([1.0, 0.4], n=6, noise_std=0.05, seed=4)
    _, S0 = generate_push_data([1.0, 0.4], n=6, noise_std=0.0, seed=4)
    assert np.array_equal(S1, S2) and not np.array_equal(S1, S3)
    np.testing.assert_allclose(S0, simulate_push([1.0, 0.4], J1))
    assert 0 < np.std(S1 - S0) < 0.2


def test_objective_is_zero_at_truth_and_on_the_ridge() -> None:
    J, S = generate_push_data([1.0, 0.4], n=8, seed=0)
    obj = PushObjective(J, S)
    assert obj([1.0, 0.4]) == pytest.approx(0.0, abs=1e-20)
    assert obj([0.8, 0.4 / 0.64]) == pytest.approx(0.0, abs=1e-20)
    assert obj([1.2, 0.4]) > 0.01
    res = obj.evaluate_batch(np.array([[1.0, 0.4], [1.2, 0.4]]))
    assert res.status == ("ok", "ok") and res.errors[1] > 0.01
    assert obj.n_observations == 8 and obj.noise_var is None
    assert PushObjective(J, S, noise_std=0.1).noise_var == pytest.approx(0.01)
    assert obj.fingerprint() == PushObjective(J, S).fingerprint() != PushObjective(J, S + 1e-9).fingerprint()


def test_fail_above_raises_physics_error_and_batch_marks_failed() -> None:
    J, S = generate_push_data([1.0, 0.4], n=4, seed=0)
    obj = PushObjective(J, S, fail_above=1.3)
    with pytest.raises(PhysicsError, match="fail_above"):
        obj([1.4, 0.4])
    seen = []
    res = obj.evaluate_batch(np.array([[1.0, 0.4], [1.4, 0.4]]), on_result=lambda *row: seen.append(row))
    assert res.status == ("ok", "diverged") and "fail_above" in res.messages[1]
    assert np.isnan(res.errors[1]) and np.isnan(res.parts[1]).all() and res.parts.shape == (2, 2)
    assert seen[0][1] == res.errors[0] and np.isnan(seen[1][1])
    assert [(row[0], row[2]) for row in seen] == [(0, "ok"), (1, "diverged")]
    np.testing.assert_array_equal(seen[0][5], res.parts[0])


def test_parts_residuals_and_segments() -> None:
    J, S = generate_push_data([1.0, 0.4], n=7, noise_std=0.05, seed=1)
    obj = PushObjective(J, S)
    theta = np.array([1.1, 0.5])
    assert obj.segments == ("w0", "w1") and obj.fingerprint()["segments"] == ["w0", "w1"]
    parts = obj.evaluate_parts(theta)
    assert parts.shape == (2,) and obj(theta) == parts.sum()
    assert np.isclose(parts.sum(), np.sum((S - simulate_push(theta, J)) ** 2), rtol=1e-14)
    res = obj.residuals(theta)
    assert [r.shape for r in res] == [(4, 1), (3, 1)]          # contiguous, sizes differ by at most one
    np.testing.assert_allclose(np.concatenate(res)[:, 0], S - simulate_push(theta, J))
    assert np.isclose(sum(np.sum(r**2) for r in res), obj(theta))
    batch = obj.evaluate_batch(np.array([theta, [1.0, 0.4]]))
    np.testing.assert_array_equal(batch.parts[0], parts)
    assert batch.errors.tolist() == batch.parts.sum(axis=1).tolist()
    assert PushObjective(J, S, windows=3).segments == ("w0", "w1", "w2")
    assert PushObjective(J[:2], S[:2], windows=5).segments == ("w0", "w1")   # fewer pushes than windows
    assert PushObjective(J, S, windows=1).fingerprint() != obj.fingerprint()


def test_batch_records_out_of_box_rows_as_failed() -> None:
    J, S = generate_push_data([1.0, 0.4], n=4, seed=0)
    res = PushObjective(J, S).evaluate_batch(np.array([[2.0, 0.4]]))
    assert res.status == ("failed",) and "ParameterError" in res.messages[0]


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: simulate_push([1.0, 0.4], []), "impulses must be a non-empty"),
        (lambda: simulate_push([1.0, 0.4], [1.0, -1.0]), "non-negative"),
        (lambda: simulate_push([1.0, 0.4, 3.0], [1.0]), "shape"),
        (lambda: simulate_push([0.0, 0.4], [1.0]), "non-physical"),
        (lambda: generate_push_data([1.0, 0.4], n=0), "positive number of pushes"),
        (lambda: generate_push_data([1.0, 0.4], noise_std=-1.0), "noise_std"),
        (lambda: PushObjective([1.0, 2.0], [1.0]), "observed must have the shape"),
        (lambda: PushObjective([1.0], [np.nan]), "NaN"),
        (lambda: PushObjective([1.0], [1.0], noise_std=0.0), "noise_std"),
        (lambda: PushObjective([1.0], [1.0])([2.0, 0.4]), "outside its bounds"),
        (lambda: PushObjective([1.0], [1.0])(np.ones((2, 2))), "evaluate_batch"),
        (lambda: push_space(mass=(1.0, 0.5)), "lower bound must be below"),
        (lambda: PushObjective([1.0], [1.0], windows=0), r"windows must be an integer >= 1.*windows=1"),
        (lambda: PushObjective([1.0], [1.0], windows=2.0), "windows must be an integer"),
        (lambda: PushObjective([1.0], [1.0]).evaluate_batch(np.ones((2, 3))), r"thetas must have shape \(n, 2\)"),
    ],
)
def test_validation(call, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        call()
