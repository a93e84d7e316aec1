"""An objective that counts the evaluations of E(θ) made through it, so that a run reports every
evaluation it spends, those after its search (σ² residuals, Gauss-Newton steps: belief.assess)
included, and a budget can be checked against them."""
from __future__ import annotations

from typing import Any

import numpy as np

from physics.errors import NoResidualsError
from physics.objective import BatchResult, Objective, OnResult

__all__ = ["CountingObjective"]


class CountingObjective:
    """The objective contract of ``inner``, counting in ``evaluations`` every θ passed to
    ``__call__``, ``evaluate_parts``, ``evaluate_batch``, ``residuals`` or ``residuals_batch``
    (one row, one evaluation), except the calls an objective without residual vectors refuses
    (:class:`NoResidualsError`: nothing was simulated)."""

    def __init__(self, inner: Objective) -> None:
        self.inner = inner
        self.space = inner.space
        self.evaluations = 0

    @property
    def segments(self) -> tuple[str, ...]:
        return tuple(self.inner.segments)

    @property
    def n_observations(self) -> int:
        return int(self.inner.n_observations)

    @property
    def noise_var(self) -> float | None:
        return self.inner.noise_var

    @property
    def noise_floor(self) -> float | None:
        return self.inner.noise_floor

    def __call__(self, theta: np.ndarray) -> float:
        self.evaluations += 1
        return self.inner(theta)

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        self.evaluations += 1
        return self.inner.evaluate_parts(theta)

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: OnResult | None = None) -> BatchResult:
        self.evaluations += len(np.atleast_2d(thetas))
        return self.inner.evaluate_batch(thetas, on_result=on_result)

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        refused = False
        try:
            return self.inner.residuals(theta)
        except NoResidualsError:
            refused = True
            raise
        finally:                    # a simulation that diverged was run: it counts
            self.evaluations += 0 if refused else 1

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        refused = False
        try:
            return self.inner.residuals_batch(thetas)
        except NoResidualsError:
            refused = True
            raise
        finally:
            self.evaluations += 0 if refused else len(np.atleast_2d(thetas))

    def fingerprint(self) -> dict[str, Any]:
        return self.inner.fingerprint()

    def __repr__(self) -> str:
        return f"CountingObjective({self.inner!r}, evaluations={self.evaluations})"
