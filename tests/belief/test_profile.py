"""Profile-likelihood intervals (belief.profile): the Laplace width where E is quadratic, E's own
width where it flattens, the box's face where the data never object."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from belief.errors import BeliefError
from belief.profile import ProfileConfig, profile_widths
from physics import ParameterSpace
from physics.objective import BatchResult, evaluate_row, residual_row
from physics.parameters import Parameter

SIGMA = 0.05
LEVEL_Z = 1.6449


class Residuals:
    """E(θ) = ||r(θ)||² for a residual function r over the unit box, in two segments."""

    segments = ("a", "b")

    def __init__(self, r: Callable[[np.ndarray], np.ndarray], dim: int) -> None:
        self.r = r
        self.space = ParameterSpace(tuple(Parameter(f"p{j}", "1", 0.5, 0.0, 1.0, "", minimum=-np.inf)
                                          for j in range(dim)))

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        return [part[:, None] for part in np.array_split(self.r(np.asarray(theta, float)), 2)]

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        return np.array([float(np.sum(r ** 2)) for r in self.residuals(theta)])

    def evaluate_batch(self, thetas: np.ndarray, **_: object) -> BatchResult:
        return BatchResult.from_rows([evaluate_row(self, t) for t in np.atleast_2d(thetas)], 2)

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        return [residual_row(self, t) for t in np.atleast_2d(thetas)]


def _saturating(width: float, seed: int = 0) -> tuple[Residuals, np.ndarray, np.ndarray, np.ndarray]:
    """r = A ([h(θ0), θ1] − [h(c0), c1]) with h(x) = c0 + w tanh((x − c0)/w): noise-free, minimum at c,
    where J = A; E flattens along θ0 beyond w. Returns (objective, c, J, Laplace covariance)."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(60, 2))
    A[:, 1] += 0.6 * A[:, 0]                                    # correlated, so the others must follow
    c = np.array([0.5, 0.45])
    h = (lambda x: c[0] + width * np.tanh((x - c[0]) / width)) if np.isfinite(width) else (lambda x: x)
    obj = Residuals(lambda t: A @ (np.array([h(t[0]), t[1]]) - c), 2)
    return obj, c, A, SIGMA ** 2 * np.linalg.inv(A.T @ A)


def test_where_e_is_quadratic_the_profile_is_the_laplace_width() -> None:
    obj, c, J, cov = _saturating(np.inf)
    out = profile_widths(obj, c, J, cov, SIGMA ** 2)
    t0 = LEVEL_Z * np.sqrt(np.diag(cov))
    np.testing.assert_allclose(out.half, np.column_stack([t0, t0]), rtol=0.03)
    np.testing.assert_allclose(out.stretch, 1.0, atol=0.03)
    assert out.best_nats == pytest.approx(0.0, abs=1e-9)


def test_where_e_flattens_the_profile_finds_its_own_width() -> None:
    t0 = LEVEL_Z * np.sqrt(_saturating(np.inf)[3][0, 0])
    width = 1.25 * t0                                           # the threshold is reachable, 1.4 t0 out
    obj, c, J, cov = _saturating(width)
    out = profile_widths(obj, c, J, cov, SIGMA ** 2)
    exact = width * np.arctanh(t0 / width)                      # h(c0 + x) − c0 = t0 there
    np.testing.assert_allclose(out.half[0], [exact, exact], rtol=0.05)
    assert out.stretch[0] == pytest.approx(exact / t0, rel=0.05) and out.stretch[0] > 1.1
    assert out.stretch[1] >= 1.0


def test_where_the_data_never_object_the_interval_reaches_the_face() -> None:
    t0 = LEVEL_Z * np.sqrt(_saturating(np.inf)[3][0, 0])
    obj, c, J, cov = _saturating(0.8 * t0)                      # h saturates below the threshold
    out = profile_widths(obj, c, J, cov, SIGMA ** 2, config=ProfileConfig(rounds=4))
    np.testing.assert_allclose(out.half[0], [c[0], 1 - c[0]], rtol=1e-6)
    assert out.stretch[0] > 5, out.half


def test_wide_parameters_are_not_profiled_and_a_failed_centre_is_refused() -> None:
    obj, c, J, cov = _saturating(np.inf)
    out = profile_widths(obj, c, J, cov * 1e4, SIGMA ** 2)      # every Laplace interval spans the box
    assert out.evaluations == 1 and np.all(out.stretch == 1.0) and np.isnan(out.half).all()
    broken = Residuals(lambda t: np.full(4, np.inf), 2)
    with pytest.raises(BeliefError, match="centre failed"):
        profile_widths(broken, c, J, cov, SIGMA ** 2)
    with pytest.raises(BeliefError, match="reach"):
        ProfileConfig(reach=1.0)
