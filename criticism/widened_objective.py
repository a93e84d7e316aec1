"""An objective presented in another box and on some of its segments: the wider-box test's view of E.

The trajectory objective evaluates any physical θ, whatever its box (physics.trajectory_objective
evaluates with the bounds unchecked), and belief's least-squares fits take their unit coordinates
u = (θ − lower) / (upper − lower) from ``objective.space``. So re-fitting in a wider box needs only the
same objective with another ``space``; and a fit on the fit segments F alone (criticism's split into
fit and held-out segments) needs the same objective with the others left out::

    E_F(θ) = Σ_{s in F} E_s(θ)          parts (|F|,), residuals |F| arrays

:class:`WidenedObjective` is that view (physics.objective.Objective): every member forwards to the
wrapped objective and keeps the parts and residuals of F. It is used by criticism.wider_box.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from criticism.errors import CriticismError
from physics.objective import BatchResult, Objective, OnResult
from physics.parameters import ParameterSpace

__all__ = ["WidenedObjective"]


class WidenedObjective:
    """``objective`` in the box ``space`` (the objective's parameters, other bounds) on the segments
    ``fit`` (a boolean mask over its S segments; None: all), module docstring."""

    def __init__(self, objective: Objective, space: ParameterSpace, fit: Sequence[bool] | np.ndarray | None = None
                 ) -> None:
        if tuple(space.names) != tuple(objective.space.names):
            raise CriticismError(f"a widened space must have the objective's parameters {list(objective.space.names)}, "
                                 f"got {list(space.names)}.")
        mask = np.ones(len(objective.segments), bool) if fit is None else np.asarray(fit, bool)
        if mask.shape != (len(objective.segments),) or not mask.any():
            raise CriticismError(f"fit must be a boolean mask over the objective's {len(objective.segments)} segments "
                                 "with at least one True.")
        self.objective, self.space, self.mask = objective, space, mask

    @property
    def segments(self) -> tuple[str, ...]:
        """The names of the kept segments."""
        return tuple(name for name, keep in zip(self.objective.segments, self.mask, strict=True) if keep)

    @property
    def n_observations(self) -> int:
        """K of the kept segments: the objective's K, shared in proportion to the segments kept (the
        windows of a trajectory objective are of about equal length)."""
        return max(1, round(self.objective.n_observations * self.mask.mean()))

    @property
    def noise_var(self) -> float | None:
        """σ² per residual of the wrapped objective (units of E), or None."""
        return self.objective.noise_var

    @property
    def noise_floor(self) -> float | None:
        """s₀² of the wrapped objective, or None."""
        return self.objective.noise_floor

    def __call__(self, theta: np.ndarray) -> float:
        """E_F(θ)."""
        return float(self.evaluate_parts(theta).sum())

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        """The parts (|F|,) of the kept segments at θ (D,)."""
        return np.asarray(self.objective.evaluate_parts(theta), float)[self.mask]

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: OnResult | None = None) -> BatchResult:
        """The wrapped objective's batch with the parts of the kept segments, E_F = their sum on ok rows."""
        def kept(k: int, error: float, status: str, seconds: float, message: str, parts: np.ndarray) -> None:
            part = np.asarray(parts, float)[self.mask]
            assert on_result is not None
            on_result(k, float(part.sum()) if status == "ok" else error, status, seconds, message, part)

        result = self.objective.evaluate_batch(thetas, on_result=None if on_result is None else kept)
        parts = result.parts[:, self.mask]
        ok = np.array([s == "ok" for s in result.status], bool)
        errors = np.where(ok, np.where(ok[:, None], parts, 0.0).sum(axis=1), np.nan)
        return BatchResult(errors, result.status, result.seconds, result.messages, parts)

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        """The residuals (|F| arrays (T_s, m)) of the kept segments at θ."""
        return [r for r, keep in zip(self.objective.residuals(theta), self.mask, strict=True) if keep]

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        """:meth:`residuals` at each row of θs (n, D), None where the evaluation was not ok."""
        return [None if rows is None else [r for r, keep in zip(rows, self.mask, strict=True) if keep]
                for rows in self.objective.residuals_batch(thetas)]

    def fingerprint(self) -> dict[str, Any]:
        """The objective's fingerprint with the box and the kept segments."""
        return {"kind": "widened box", "objective": self.objective.fingerprint(),
                "lower": self.space.lower.tolist(), "upper": self.space.upper.tolist(),
                "segments": list(self.segments)}
