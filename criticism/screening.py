"""The screening fit of an effect: its parameters η fitted with the model's parameters held.

Given an objective whose parameter vector ends with the effect's k parameters, θ = (θ_model, η),
each η_j in turn is set to the best of ``grid`` values over its box (plus its current value),
then of ``refine`` values within one grid step of that best, the others held. The score is the
sum of the segment errors over the ``fit`` mask. A coordinate search on a grid is robust to the
flat and ragged error surfaces an effect meets on data it does not fit, and costs
k (grid + refine) evaluations, batched per parameter.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from physics.effect_objective import EffectObjective
from physics.effects import Effect
from physics.objective import BatchResult, Objective

__all__ = ["fit_effect", "effect_start"]


def _scores(result: BatchResult, mask: np.ndarray) -> np.ndarray:
    """Σ parts over ``mask`` per row, inf where the evaluation failed."""
    ok = np.array([s == "ok" for s in result.status])
    return np.where(ok, np.nan_to_num(result.parts[:, mask], nan=0.0).sum(axis=1), np.inf)


def fit_effect(objective: Objective, theta: np.ndarray, indices: Sequence[int], fit: np.ndarray, *,
               grid: int = 7, refine: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """Fit the parameters ``indices`` of θ (D,) on the segments ``fit`` (S,) bool, the others held
    (module docstring). Returns (θ̂ (D,), parts (S,) at θ̂); parts are inf when every value failed."""
    theta = np.array(theta, dtype=float)
    lower, upper = objective.space.lower, objective.space.upper
    parts = np.full(len(objective.segments), np.inf)
    for rnd in ("grid", "refine"):
        for j in indices:
            step = (upper[j] - lower[j]) / (grid - 1)
            if rnd == "grid":
                values = np.unique(np.r_[np.linspace(lower[j], upper[j], grid), theta[j]])
            else:
                values = np.linspace(max(lower[j], theta[j] - step), min(upper[j], theta[j] + step), refine)
            rows = np.repeat(theta[None], len(values), axis=0)
            rows[:, j] = values
            result = objective.evaluate_batch(rows)
            score = _scores(result, fit)
            if np.isfinite(score).any():
                k = int(np.argmin(score))
                theta[j], parts = values[k], np.asarray(result.parts[k], float)
    return theta, parts


def effect_start(objective: EffectObjective, theta: np.ndarray,
                 effect: Effect) -> tuple[EffectObjective, np.ndarray, list[int]]:
    """The objective with ``effect`` added, θ (D,) extended by the effect's starting values (read
    from the data where the effect can, Effect.start) to (D + k,), and the k indices of η."""
    extended = objective.with_effects(tuple(objective.effects) + (effect,))
    values = effect.start(objective.trajectories)
    start = [values[p.name] for p in effect.parameters()]
    return extended, np.r_[theta, start], list(range(len(theta), len(theta) + len(start)))
