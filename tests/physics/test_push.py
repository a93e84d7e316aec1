"""The push toy S = J^2 / (2 m^2 mu): ridge invariance, shapes, data generation, objective, validation."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from physics.errors import ParameterError, PhysicsError
from physics.push import PushError, generate_push_data, push_space, simulate_push


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
    obj = PushError(J, S)
    assert obj([1.0, 0.4]) == pytest.approx(0.0, abs=1e-20)
    assert obj([0.8, 0.4 / 0.64]) == pytest.approx(0.0, abs=1e-20)
    assert obj([1.2, 0.4]) > 0.01
    res = obj.evaluate_batch(np.array([[1.0, 0.4], [1.2, 0.4]]))
    assert res[0][1] == "ok" and res[1][0] > 0.01
    assert obj.n_observations == 8 and obj.noise_var is None
    assert PushError(J, S, noise_std=0.1).noise_var == pytest.approx(0.01)
    assert obj.fingerprint() == PushError(J, S).fingerprint() != PushError(J, S + 1e-9).fingerprint()


def test_fail_above_raises_physics_error_and_batch_marks_failed() -> None:
    J, S = generate_push_data([1.0, 0.4], n=4, seed=0)
    obj = PushError(J, S, fail_above=1.3)
    with pytest.raises(PhysicsError, match="fail_above"):
        obj([1.4, 0.4])
    assert obj.evaluate_batch(np.array([[1.4, 0.4]]))[0][1] == "failed"


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: simulate_push([1.0, 0.4], []), "impulses must be a non-empty"),
        (lambda: simulate_push([1.0, 0.4], [1.0, -1.0]), "non-negative"),
        (lambda: simulate_push([1.0, 0.4, 3.0], [1.0]), "shape"),
        (lambda: simulate_push([0.0, 0.4], [1.0]), "non-physical"),
        (lambda: generate_push_data([1.0, 0.4], n=0), "positive number of pushes"),
        (lambda: generate_push_data([1.0, 0.4], noise_std=-1.0), "noise_std"),
        (lambda: PushError([1.0, 2.0], [1.0]), "observed must have the shape"),
        (lambda: PushError([1.0], [np.nan]), "NaN"),
        (lambda: PushError([1.0], [1.0], noise_std=0.0), "noise_std"),
        (lambda: PushError([1.0], [1.0])([2.0, 0.4]), "outside its bounds"),
        (lambda: PushError([1.0], [1.0])(np.ones((2, 2))), "evaluate_batch"),
        (lambda: push_space(mass=(1.0, 0.5)), "lower bound must be below"),
    ],
)
def test_validation(call, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        call()
