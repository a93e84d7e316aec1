"""Effects on the observations: a constant bias of the motion-capture positions."""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from physics.effects.base import Effect, ModelSetup
from physics.parameters import Parameter

__all__ = ["SensorBias"]


class SensorBias(Effect):
    """Every observed node is offset by ``sensor_bias_z`` [m] along z (a miscalibrated ground
    plane of the motion capture). Offsets along x and y are left out: the T6's motion is
    invariant to them, so no data can identify them."""

    name = "sensor_bias"
    description = "constant vertical offset of the observed positions"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("sensor_bias_z", "m", 0.0, -0.05, 0.05, "vertical offset of the observations",
                          minimum=-np.inf),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.observation_offset = setup.observation_offset + np.array([0.0, 0.0, values["sensor_bias_z"]])
