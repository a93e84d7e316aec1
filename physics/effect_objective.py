"""The effect-aware objective contract: what model criticism calls to add effects to a model,
split its data and look at its predictions.

An :class:`EffectObjective` is an :class:`~physics.objective.Objective` E(θ) = Σ_s E_s(θ) on
observed trajectories of a model built from the T6 and effects e_1..e_m, so that θ (D,) lives in
``model_space(effects)`` (15 T6 parameters, then each effect's). Beyond the objective contract:

- ``effects``: the model's effects (:class:`~physics.effects.Effect`), in the order their
  parameters extend θ;
- ``loss``: ``"squared"`` (E = Σ ||r||², a Gaussian log-likelihood up to scale, which criticism's
  evidence needs) or ``"norm"`` (E = Σ ||r||);
- ``trajectories``: the observed Datasets (docs/data-format.md); segment ``f"t{k}/w{j}"`` belongs
  to trajectory k;
- ``with_effects(effects)``: the same data and settings on the model with ``effects`` instead
  (θ then has D' = 15 + Σ parameters of ``effects``);
- ``select(indices)``: the same settings on a subset of the trajectories, renumbered t0.. in the
  given order;
- ``predictions(θ (D,))``: predicted node positions per trajectory, DataArrays (time, node, axis)
  [m] in the layout of each trajectory's ``nodes``, NaN where nothing was predicted;
- ``close()``: release the worker pool the objective and its derived objectives share.

:class:`physics.trajectory_objective.TrajectoryObjective` implements it. This module loads neither the simulator
nor the effects (numpy and typing only at run time), so code typed against it stays cheap to import.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from physics.objective import Objective

if TYPE_CHECKING:
    import xarray as xr

    from physics.effects.base import Effect

__all__ = ["EffectObjective"]


@runtime_checkable
class EffectObjective(Objective, Protocol):
    """Structural type of an objective on trajectories of a model with effects (module docstring).

    θ has shape (D,) with D = ``space.dim`` = 15 + the effects' parameter count; parts (S,) with
    S = ``len(segments)``; ``predictions`` returns one (T_k, 12, 3) DataArray per trajectory.
    """

    effects: tuple[Effect, ...]
    loss: str
    trajectories: list[xr.Dataset]

    def with_effects(self, effects: Sequence[Effect]) -> EffectObjective:
        """The same data and settings on the T6 with ``effects`` (θ in ``model_space(effects)``)."""
        ...

    def select(self, trajectories: Sequence[int]) -> EffectObjective:
        """The same settings on the trajectories at these indices, segments renumbered in that order."""
        ...

    def predictions(self, theta: np.ndarray) -> list[xr.DataArray]:
        """Predicted node positions [m] per trajectory, (time, node, axis), NaN where not predicted."""
        ...

    def close(self) -> None:
        """Release the worker pool shared with the objectives derived by with_effects and select."""
        ...
