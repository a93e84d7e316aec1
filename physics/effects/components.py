"""Effects that replace a component of the model: the cable law's coefficients and the actuator."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from physics.actuators import RateLimitedActuator
from physics.effects.base import Effect, ModelSetup
from physics.errors import ParameterError
from physics.parameters import Parameter

__all__ = ["CableHysteresis", "NonlinearStiffness", "ActuatorDelay", "RateLimitedActuation", "EncoderOffset"]


class CableHysteresis(Effect):
    """Cables stiffer while lengthening than while shortening: k (1 + hysteresis) when dL/dt > 0
    (physics.cables.cable_tension); the difference dissipates energy over a cycle."""

    name = "cable_hysteresis"
    description = "cables stiffer lengthening than shortening"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("hysteresis", "1", 0.0, 0.0, 1.0, "relative extra stiffness while lengthening",
                          strict=False),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.cable = replace(setup.cable, hysteresis=float(values["hysteresis"]))


class NonlinearStiffness(Effect):
    """Nonlinear cable stiffness: F_k = k s (1 + stiffness_quadratic · s), s the stretch [m]."""

    name = "nonlinear_stiffness"
    description = "cable force quadratic in the stretch"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("stiffness_quadratic", "1/m", 0.0, -2.0, 6.0, "relative stiffening per metre of stretch",
                          minimum=-np.inf),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.cable = replace(setup.cable, quadratic=float(values["stiffness_quadratic"]))


class ActuatorDelay(Effect):
    """The actuators see each command ``actuator_delay`` [s] after it was sent (bus and firmware latency)."""

    name = "actuator_delay"
    description = "delay between a command and the actuator acting on it"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("actuator_delay", "s", 0.0, 0.0, 0.15, "command latency", strict=False),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.command_delay += float(values["actuator_delay"])


class RateLimitedActuation(Effect):
    """An ideal rate-limited actuator instead of the motor model: each rest length follows its
    target at ``actuator_rate`` [m/s] (physics.actuators.RateLimitedActuator). A replacement: no
    value of its parameter gives back the motor model, only leaving the effect out does."""

    name = "rate_limited_actuator"
    description = "rest lengths follow targets at a fixed speed (no motor dynamics)"
    switchable = False

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("actuator_rate", "m/s", 0.5, 0.1, 2.0, "speed of rest-length change"),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.actuator = RateLimitedActuator(float(values["actuator_rate"]), setup.gains, setup.dt)


class EncoderOffset(Effect):
    """One cable's encoder is zeroed wrong: the actuator of cable ``cable`` reaches the commanded
    rest length plus ``encoder_offset`` [m]. Not in the default catalog: it stands for the effects
    a catalog lacks (tests and benchmarks use it as the undeclared effect nobody listed)."""

    name = "encoder_offset"
    description = "one cable's rest lengths offset by a mis-zeroed encoder"

    def __init__(self, cable: int = 3) -> None:
        if cable not in range(24):
            raise ParameterError(f"EncoderOffset.cable must be a cable index in 0..23, got {cable!r}.")
        self.cable = int(cable)

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("encoder_offset", "m", 0.0, -0.1, 0.1, "rest-length offset of one cable", minimum=-np.inf),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        offset = setup.command_offset.copy()
        offset[self.cable] += float(values["encoder_offset"])
        setup.command_offset = offset

    def config(self) -> dict:
        return {"effect": self.name, "cable": self.cable}
