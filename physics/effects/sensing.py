"""Effects on the observations: a constant bias of the motion-capture positions."""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr

from physics.effects.base import Effect, ModelSetup
from physics.effects.world import MEASURED_CONTACT_WIDTH, contact_excess
from physics.errors import ParameterError
from physics.parameters import Parameter

__all__ = ["SensorBias", "EVIDENT_OFFSET", "FLOPS_OFFSET_WIDTH"]

#: offset [m] beyond which a bias read from the flops' contact law is evident (SensorBias.evident):
#: twice the largest offset that law reads on the foreign testbed's data without one (2.4 mm over
#: 24 data sets, benchmarks/contact_law.py)
EVIDENT_OFFSET = 0.005
#: ± half-width [m] of the box around a bias read from the flops' contact law
FLOPS_OFFSET_WIDTH = 0.005


class SensorBias(Effect):
    """Every observed node is offset by ``sensor_bias_z`` [m] along z (a miscalibrated ground
    plane of the motion capture). Offsets along x and y are left out: the T6's motion is
    invariant to them, so no data can identify them.

    ``measured``: the bias the resting robot shows (:meth:`bind`): its contact nodes are seen at
    h = r + b, r the caps' contact radius (the nominal rod radius), so b = h − r
    (physics.effects.world.contact_excess). The parameter then keeps a box of ± ``width`` around
    it: a fit of the dynamics cannot sink the model's robot into the floor (or lift it off) where
    the resting robot shows it is not.

    ``from_flops``: the bias was read from the flops instead (physics.contact_law: the flat-end law
    h = b + r cos α, which separates b from r where the rest pose cannot; criticism.contact). Such a
    bias is evident beyond EVIDENT_OFFSET when its box leaves out zero, and joins the model
    without a search."""

    name = "sensor_bias"
    description = "constant vertical offset of the observed positions"

    def __init__(self, measured: float | None = None, width: float = MEASURED_CONTACT_WIDTH,
                 from_flops: bool = False) -> None:
        if measured is not None and not np.isfinite(measured):
            raise ParameterError(f"SensorBias measured must be a finite offset [m], got {measured!r}.")
        if not (np.isfinite(width) and width > 0):
            raise ParameterError(f"SensorBias width must be a positive length [m], got {width!r}.")
        if from_flops and measured is None:
            raise ParameterError("SensorBias(from_flops=True) needs the measured offset [m].")
        self.measured = None if measured is None else float(measured)
        self.width = float(width)
        self.from_flops = bool(from_flops)

    def parameters(self) -> tuple[Parameter, ...]:
        if self.measured is None:
            return (Parameter("sensor_bias_z", "m", 0.0, -0.05, 0.05, "vertical offset of the observations",
                              minimum=-np.inf),)
        b, source = self.measured, "read from the flops" if self.from_flops else "measured at rest"
        return (Parameter("sensor_bias_z", "m", b, b - self.width, b + self.width,
                          f"vertical offset of the observations ({source})", minimum=-np.inf),)

    @property
    def evident(self) -> bool:
        """A bias read from the flops beyond EVIDENT_OFFSET whose box leaves out zero; one measured
        at rest never is (there it is one number with the caps' radius)."""
        return (self.from_flops and self.measured is not None
                and abs(self.measured) > max(EVIDENT_OFFSET, self.width))

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
        flops = {"from_flops": True} if self.from_flops else {}
        return {"effect": self.name, "measured": self.measured, "width": self.width, **flops}
