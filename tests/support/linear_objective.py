"""A cheap objective with residual vectors and a known answer, for the belief tests.

E(θ) = ||y − A m(θ)||² over the unit box (m(θ) = θ; a subclass bends it), split into ``segments``
equal parts; ``noise_var`` (σ² known to belief, or None) and ``noise_floor`` (the residual
variance the data's noise alone leaves, as a trajectory objective measures it) are declared as the
objective contract (physics.objective) asks.
"""
from __future__ import annotations

import numpy as np

from physics.objective import BatchResult, OnResult, evaluate_row, residual_row
from physics.parameters import Parameter, ParameterSpace

__all__ = ["unit_space", "LinearObjective"]


def unit_space(dim: int) -> ParameterSpace:
    """Parameters p0..p{dim-1}, each on [0, 1] with nominal 0.5."""
    return ParameterSpace(tuple(Parameter(f"p{j}", "1", 0.5, 0.0, 1.0, "", minimum=-np.inf) for j in range(dim)))


class LinearObjective:
    """The module docstring's objective; ``mean`` is the model's prediction A m(θ)."""

    def __init__(self, A: np.ndarray, y: np.ndarray, *, segments: int = 1, noise_var: float | None = None,
                 noise_floor: float | None = None) -> None:
        self.A, self.y, self.space = np.asarray(A, float), np.asarray(y, float), unit_space(np.shape(A)[1])
        self.segments = tuple(f"w{k}" for k in range(segments))
        self._noise_var, self._noise_floor = noise_var, noise_floor

    n_observations = property(lambda self: int(self.y.size))
    noise_var = property(lambda self: self._noise_var)
    noise_floor = property(lambda self: self._noise_floor)

    def mean(self, theta: np.ndarray) -> np.ndarray:
        return self.A @ np.asarray(theta, float)

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        return [part[:, None] for part in np.array_split(self.y - self.mean(theta), len(self.segments))]

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        return np.array([float(np.sum(r ** 2)) for r in self.residuals(theta)])

    def __call__(self, theta: np.ndarray) -> float:
        return float(self.evaluate_parts(theta).sum())

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: OnResult | None = None) -> BatchResult:
        rows = [evaluate_row(self, t) for t in np.atleast_2d(thetas)]
        for k, row in enumerate(rows):
            if on_result is not None:
                on_result(k, *row)
        return BatchResult.from_rows(rows, len(self.segments))

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        return [residual_row(self, t) for t in np.atleast_2d(thetas)]

    def fingerprint(self) -> dict[str, object]:
        return {"kind": f"{type(self).__name__}-test", "y": self.y.tolist(), "segments": len(self.segments),
                "noise_var": self._noise_var}
