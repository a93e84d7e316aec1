"""Replication across trajectories: an effect the data carry, fitted without a trajectory, still
predicts that trajectory better.

The held-out score of criticism.search is one split: fit on F, score on H. Under model error
(another engine, a real robot) an extra freedom can absorb part of what the model lacks without
being the physics the data carry. When its size follows each trajectory's own mismatch (a
floor tilt fitted to each flop of another engine's robot on a flat floor), it does not carry
over from one trajectory to another. Replication asks it to:

    for each fit trajectory g:
        η̂₋g   = screening fit of η on F ∖ g, θ̃ held          (criticism.screening)
        gain_g = 1 - E_g(θ̃, η̂₋g) / E_g(θ̃)

An effect is found only when every gain_g ≥ CriticismConfig.min_replication (default 0: fitted on
the others, the effect never makes a trajectory worse). The check needs two fit trajectories;
with fewer it is skipped (no gains). A freedom that absorbs a mismatch all trajectories share
replicates like a cause, and this check cannot tell them apart.

Holding θ̃ is not neutral when the model's parameters partly mimic the effect: θ̃ was re-tuned on
all of F without it (a drag traded against the cables' damping), so an η fitted on F ∖ g on top
of θ̃ can overshoot on g. The *refit* check gives the model alone and the model with the effect
the same freedom:

    θ̂₋g       = least squares of θ on F ∖ g, from θ̃                  (the model alone)
    (θ, η)̂₋g  = least squares of (θ, η) on F ∖ g, from the joint fit (θ̂_e, η̂_e)
    refit_g   = 1 - E_g((θ, η)̂₋g) / E_g(θ̂₋g)

Criticism runs it only where it decides a verdict (criticism.search, step 3): the top effect
passes both bars but does not replicate with θ̃ held.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from belief import least_squares
from belief.least_squares import LeastSquaresConfig
from criticism.screening import effect_start, fit_effect
from physics.effect_objective import EffectObjective
from physics.effects import Effect

__all__ = ["fit_groups", "replication_gains", "refit_replication_gains"]


def fit_groups(segments: Sequence[str], fit: np.ndarray) -> dict[str, np.ndarray]:
    """Masks (S,) of the fit trajectories (segment names "t{k}/w{j}"); {} when fewer than two are fit.
    Windows of one trajectory are no groups: a window need not carry the effect at all (a delay
    shows only while the actuators move)."""
    fit = np.asarray(fit, bool)
    trajectory = np.array([s.split("/")[0] for s in segments])
    names = list(dict.fromkeys(trajectory[fit].tolist()))
    return {n: fit & (trajectory == n) for n in names} if len(names) >= 2 else {}


def replication_gains(objective: EffectObjective, theta: np.ndarray, effect: Effect, fit: np.ndarray, *,
                      grid: int = 7, refine: int = 5) -> dict[str, float]:
    """gain_g (module docstring) of ``effect`` (not in ``objective``) for each fit trajectory, with
    the model's parameters held at θ̃ (D,); -inf where the effect's fit fails, {} with fewer than two."""
    groups = fit_groups(objective.segments, fit)
    if not groups:
        return {}
    base = np.asarray(objective.evaluate_parts(np.asarray(theta, float)), float)
    extended, start, indices = effect_start(objective, np.asarray(theta, float), effect)
    gains: dict[str, float] = {}
    for name, group in groups.items():
        _, parts = fit_effect(extended, start, indices, np.asarray(fit, bool) & ~group, grid=grid, refine=refine)
        gains[name] = _gain(float(base[group].sum()), float(parts[group].sum()))
    return gains


def _gain(before: float, after: float) -> float:
    """1 - after / before; 0 when there is nothing to explain, -inf when the fit failed."""
    if not math.isfinite(after):
        return -math.inf
    return 1.0 - after / before if before > 0 else 0.0


def refit_replication_gains(objective: EffectObjective, theta: np.ndarray, joint_theta: np.ndarray, effect: Effect,
                            fit: np.ndarray, config: LeastSquaresConfig) -> dict[str, float]:
    """refit_g (module docstring) of ``effect`` (not in ``objective``) for each fit trajectory: the
    model alone re-tuned from θ̃ (D,), the model with the effect from its joint fit (D + k,), both by
    ``config``'s least squares on the other fit trajectories; {} with fewer than two."""
    groups = fit_groups(objective.segments, fit)
    if not groups:
        return {}
    fit = np.asarray(fit, bool)
    extended = objective.with_effects(tuple(objective.effects) + (effect,))
    gains: dict[str, float] = {}
    for name, group in groups.items():
        alone = least_squares.refine(objective, np.asarray(theta, float), range(len(theta)), fit & ~group, config)
        both = least_squares.refine(extended, np.asarray(joint_theta, float), range(extended.space.dim),
                                    fit & ~group, config)
        gains[name] = _gain(float(alone.parts[group].sum()), float(both.parts[group].sum()))
    return gains
