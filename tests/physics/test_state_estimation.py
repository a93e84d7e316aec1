"""State estimation from recorded positions: exact on polynomials, blind to the compared sample, the noise it leaves."""
from __future__ import annotations

import numpy as np
import pytest

from physics.errors import ParameterError
from physics.state_estimation import StateEstimator, position_noise

DT = 0.01


def _poly(T: int, degree: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Positions and velocities (T x 12 x 3) of a random polynomial motion of ``degree``."""
    coef = np.random.default_rng(seed).normal(size=(degree + 1, 12, 3))
    t = np.arange(T) * DT
    x = sum(c * t[:, None, None] ** k for k, c in enumerate(coef))
    v = sum(k * c * t[:, None, None] ** (k - 1) for k, c in enumerate(coef) if k)
    return x, v


@pytest.mark.parametrize("degree", [1, 2, 3])
def test_local_polynomial_is_exact_on_polynomials_of_its_degree(degree: int) -> None:
    x, v = _poly(60, degree)
    pos, vel = StateEstimator(degree=degree, half_width=4).estimate(x, DT)
    ok = np.isfinite(vel).all(axis=(1, 2))
    assert ok.sum() >= 50
    np.testing.assert_allclose(pos[ok], x[ok], atol=1e-9)
    np.testing.assert_allclose(vel[ok], v[ok], atol=1e-6)


@pytest.mark.parametrize("ahead", [1, 3])
def test_the_state_never_sees_the_samples_it_is_compared_with(ahead: int) -> None:
    x, _ = _poly(40, 2)
    noisy = x + np.random.default_rng(1).normal(0, 1e-3, x.shape)
    i = 20
    changed = noisy.copy()
    changed[i + 1:i + 1 + ahead] += 0.5
    a = StateEstimator().estimate(noisy, DT, ahead=ahead)
    b = StateEstimator().estimate(changed, DT, ahead=ahead)
    np.testing.assert_array_equal(a[0][i], b[0][i])
    np.testing.assert_array_equal(a[1][i], b[1][i])
    assert not np.array_equal(a[1][i + 1 + ahead], b[1][i + 1 + ahead])   # it does use later ones


def test_velocity_noise_is_far_below_the_backward_difference() -> None:
    x, _ = _poly(400, 2)
    noisy = x + np.random.default_rng(2).normal(0, 1e-3, x.shape)
    _, v_poly = StateEstimator().estimate(noisy, DT)
    _, v_back = StateEstimator(method="backward").estimate(noisy, DT)
    _, v_true = StateEstimator().estimate(x, DT)
    err_poly = np.nanstd(v_poly - v_true)
    err_back = np.nanstd(v_back - v_true)
    assert err_back / err_poly > 10          # 0.255 m/s against 0.018 m/s at 1 mm


def test_missing_samples_are_left_out_and_a_missing_state_is_nan() -> None:
    x, v = _poly(50, 2)
    x[25] = np.nan
    pos, vel = StateEstimator().estimate(x, DT)
    assert np.isnan(pos[25]).all() and np.isnan(vel[25]).all()
    np.testing.assert_allclose(vel[24], v[24], atol=1e-6)      # fitted without sample 25


def test_rollout_states_use_the_past_only() -> None:
    x, _ = _poly(30, 2)
    changed = x.copy()
    changed[11:] += 1.0
    a = StateEstimator().estimate(x, DT, ahead=None)
    b = StateEstimator().estimate(changed, DT, ahead=None)
    np.testing.assert_array_equal(a[1][10], b[1][10])


@pytest.mark.parametrize("sigma", [2e-4, 1e-3, 3e-3])
def test_position_noise_is_measured_from_the_data(sigma: float) -> None:
    t = np.arange(600) * DT
    smooth = np.sin(2.0 * t)[:, None, None] * np.ones((1, 12, 3))
    noisy = smooth + np.random.default_rng(3).normal(0, sigma, smooth.shape)
    assert position_noise(noisy) == pytest.approx(sigma, rel=0.05)


def test_noise_floor_matches_white_noise_through_the_fit() -> None:
    """σ² (1 + ||w(1)||²): for the default fit 1.212 σ², for the backward difference 11.5 σ²."""
    t = np.arange(2000) * DT
    noisy = np.sin(t)[:, None, None] * np.ones((1, 12, 3)) + np.random.default_rng(4).normal(0, 1e-3, (2000, 12, 3))
    sigma2 = position_noise(noisy) ** 2
    assert StateEstimator().noise_floor(noisy, DT) / sigma2 == pytest.approx(1.212, abs=0.01)
    assert StateEstimator(method="backward").noise_floor(noisy, DT) / sigma2 == pytest.approx(11.5)


@pytest.mark.parametrize("kwargs, match", [({"method": "spline"}, "method"), ({"degree": 4}, "degree"),
                                           ({"half_width": 1}, "half_width"), ({"half_width": True}, "half_width")])
def test_bad_settings_are_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        StateEstimator(**kwargs)
