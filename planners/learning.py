"""Learning while planning: P re-weighed by every flop the robot makes.

A planner that keeps P fixed repeats a flop that works under P but not on the robot (a flop that
only rocks the robot, say) until it runs out of steps. :class:`FlopEvidence` keeps P on M cells of
the belief (:func:`planners.probe.support`, weights w) and, after each executed flop, folds its
sensed node recording y into w with the probing update (:mod:`planners.probe`)::

    w_i ← w_i exp(−‖y − f_i‖² / (2 s²)) / Σ_j w_j exp(−‖y − f_j‖² / (2 s²)),   s² = σ² d / d_eff

where f_i is the recording predicted under cell i from the same sensed start (M rollouts of the
executed flop). The next plan draws its θ from the re-weighed cells (:meth:`FlopEvidence.belief`).
σ [m] per coordinate is sensor noise plus model error; it is a setting, not an estimate.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from belief.belief import Belief
from physics.pool import DaskPool
from planners.actions import FlopAction
from planners.errors import PlannerError
from planners.probe import noise_scale, observations, restricted_belief, support, update_weights
from planners.rollouts import Outcome, RobotStart, rollouts

__all__ = ["FlopEvidence"]


class FlopEvidence:
    """P on ``cells`` cells of ``belief`` (drawn with ``seed``, ``how`` as in :func:`support`), re-weighed by
    executed flops with noise ``sigma`` [m] per coordinate (module docstring)."""

    def __init__(self, belief: Belief, *, cells: int = 32, seed: int = 0, sigma: float = 0.02,
                 how: str = "sample") -> None:
        if not (isinstance(sigma, (int, float)) and np.isfinite(sigma) and sigma > 0):
            raise PlannerError(f"sigma must be a noise std > 0 m per coordinate (sensor noise plus model error), "
                               f"got {sigma!r}.")
        self.source = belief
        self.cells, self.weights = support(belief, cells, seed=seed, how=how)
        self.sigma = float(sigma)
        self.history: list[np.ndarray] = [self.weights.copy()]

    @property
    def entropy(self) -> float:
        """H(w) [nats]."""
        w = self.weights[self.weights > 0]
        return float(-(w * np.log(w)).sum())

    def belief(self) -> Belief:
        """The source belief with P = w on the cells (:func:`planners.probe.restricted_belief`)."""
        return restricted_belief(self.source, self.cells, self.weights)

    def update(self, action: FlopAction, start: RobotStart, outcome: Outcome, *, pool: DaskPool | None = None) -> float:
        """Fold the robot's ``outcome`` of ``action`` from the sensed ``start`` into w; returns H(w) after [nats].

        The flop is simulated under every cell (M rollouts; cells the robot's status contradicts,
        ok vs diverged, get weight 0).
        """
        rs = rollouts((action,), start, self.source.theta[self.cells], pool=pool)
        F, ok = observations(rs)
        y = np.asarray(outcome.nodes, dtype=float).reshape(-1)
        if y.size != F.shape[2]:
            raise PlannerError(f"the robot's recording has {y.size} numbers, the predictions {F.shape[2]}: record the "
                               "robot's flops at the rollouts' rate (10 Hz) over the action's duration.")
        self.weights = update_weights(self.weights, F[0], ok[0], y, outcome.ok, noise_scale(F[0], ok[0], self.sigma))
        self.history.append(self.weights.copy())
        return self.entropy

    def __repr__(self) -> str:
        return f"FlopEvidence(cells={len(self.cells)}, flops={len(self.history) - 1}, entropy={self.entropy:.2f} nats)"

    def config(self) -> dict[str, Any]:
        """JSON-able settings."""
        return {"cells": int(len(self.cells)), "sigma": self.sigma}
