"""Effects on the observations: a constant bias of the motion-capture positions."""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr

from physics.effects.base import Effect, ModelSetup
from physics.effects.world import MEASURED_CONTACT_WIDTH, contact_excess
from physics.errors import ParameterError
from physics.parameters import Parameter

__all__ = ["SensorBias"]


class SensorBias(Effect):
    """Every observed node is offset by ``sensor_bias_z`` [m] along z (a miscalibrated ground
    plane of the motion capture). Offsets along x and y are left out: the T6's motion is
    invariant to them, so no data can identify them.

    ``measured``: the bias the resting robot shows (:meth:`bind`): its contact nodes are seen at
    h = r + b, r the caps' contact radius (the nominal rod radius), so b = h − r
    (physics.effects.world.contact_excess). The parameter then keeps a box of ± ``width`` around
    it: a fit of the dynamics cannot sink the model's robot into the floor (or lift it off) where
    the resting robot shows it is not."""

    name = "sensor_bias"
    description = "constant vertical offset of the observed positions"

    def __init__(self, measured: float | None = None, width: float = MEASURED_CONTACT_WIDTH) -> None:
        if measured is not None and not np.isfinite(measured):
            raise ParameterError(f"SensorBias measured must be a finite offset [m], got {measured!r}.")
        if not (np.isfinite(width) and width > 0):
            raise ParameterError(f"SensorBias width must be a positive length [m], got {width!r}.")
        self.measured = None if measured is None else float(measured)
        self.width = float(width)

    def parameters(self) -> tuple[Parameter, ...]:
        if self.measured is None:
            return (Parameter("sensor_bias_z", "m", 0.0, -0.05, 0.05, "vertical offset of the observations",
                              minimum=-np.inf),)
        b = self.measured
        return (Parameter("sensor_bias_z", "m", b, b - self.width, b + self.width,
                          "vertical offset of the observations (measured at rest)", minimum=-np.inf),)

    @property
    def off(self) -> dict[str, float] | None:
        """No bias for the free effect; None once measured (its box need not hold zero)."""
        return None if self.measured is not None else super().off

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.observation_offset = setup.observation_offset + np.array([0.0, 0.0, values["sensor_bias_z"]])

    def bind(self, trajectories: Sequence[xr.Dataset]) -> Effect:
        """The bias measured at rest (physics.effects.world.contact_excess, ± ``width``); itself when
        no trajectory starts at rest or the bias is measured already."""
        excess = contact_excess(trajectories) if self.measured is None else None
        return self if excess is None else SensorBias(measured=excess, width=self.width)

    def config(self) -> dict:
        if self.measured is None:
            return {"effect": self.name}
        return {"effect": self.name, "measured": self.measured, "width": self.width}
