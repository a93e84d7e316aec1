"""A tension-limited rate actuator (NTRT's basic actuator) in place of the motor model, as an effect
(the actuator itself is :class:`physics.actuators.TensionLimitedActuator`).

Per physics step of length dt, for each cable with rest length L0, target L_pref, tension T and
stiffness k::

    floor = L0 + (T - maxTens) / k           the shortest rest length at which T stays <= maxTens
    goal  = max(L_pref, floor)
    L0'   = max(L0 + clip(goal - L0, ±targetVelocity dt), L0_min)

so the rest length follows its target at the fixed speed ``targetVelocity`` [m/s] and the
actuator never winds a cable beyond ``maxTens`` [N]: it pays cable out when the tension exceeds
it. NTRT's basic actuator (and the Bullet testbed, docs/testbed.md) lengthens the target to
L - maxTens / k; with L - L0 = T / k for a taut cable without damping, the floor above is the same
rule written with the tension the actuator feels (damping included), which is what a real winch
senses. Unlike :class:`physics.effects.RateLimitedActuation`, it has no parameter of its own:
its speed and limit are θ's ``targetVelocity`` and ``maxTens``, so those keep their meaning and
the three motor parameters (``motor_radius``, ``motor_friction``, ``motor_inertia``) become inert.

:class:`MeasuredActuator` puts in the actuator law read from the encoders instead
(physics.actuator_readings): its delay, rate, lag, tension slack and per-cable offsets are numbers
the readings measured, not parameters of θ, so every motor parameter becomes inert.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import ClassVar

import numpy as np

from physics.actuator_laws import ActuatorLaw, LawForm
from physics.actuator_summary import ActuatorFit
from physics.actuators import LawActuator, TensionLimitedActuator
from physics.effects.base import Effect, ModelSetup
from physics.errors import ParameterError
from physics.parameters import Parameter

__all__ = ["TensionLimitedActuation", "MeasuredActuator", "MOTOR_PARAMETERS"]

#: the T6 parameters only the motor model reads (physics.actuators.MotorActuator)
MOTOR_PARAMETERS = ("maxTens", "targetVelocity", "motor_radius", "motor_friction", "motor_inertia")


class TensionLimitedActuation(Effect):
    """NTRT's basic actuator instead of the motor model: rest lengths follow their targets at
    ``targetVelocity`` and never wind a cable past ``maxTens`` (module docstring). A replacement
    without parameters of its own: only leaving it out gives back the motor model."""

    name = "tension_limited_actuator"
    description = "rest lengths follow targets at targetVelocity, tension capped at maxTens (no motor dynamics)"
    switchable = False

    def parameters(self) -> tuple[Parameter, ...]:
        return ()

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.actuator = TensionLimitedActuator(float(params["targetVelocity"]), float(params["maxTens"]),
                                                float(params["stiffnessActive"]), setup.gains, setup.dt)


class MeasuredActuator(Effect):
    """The actuator law read from the encoders (physics.actuator_readings) instead of the motor model:
    commands reach the actuators ``delay`` [s] late (the model's command delay), rest lengths follow
    them at up to ``rate`` [m/s], through a lag of ``time_constant`` [s], never winding a cable past
    the stretch ``tension_slack`` [m] (maxTens / k), ``offsets`` (24,) [m] off the command
    (physics.actuators.LawActuator). None: the law has no such part. Measured, not identified: no
    parameter of its own, and the motor parameters (:data:`MOTOR_PARAMETERS`) become inert."""

    name = "measured_actuator"
    description = "the actuator law read from the encoders (delay, rate, lag, tension limit, offsets)"
    switchable = False
    replaces: ClassVar[frozenset[str]] = frozenset({"actuator_delay", "rate_limited_actuator",
                                                    "tension_limited_actuator"})
    inert: ClassVar[tuple[str, ...]] = MOTOR_PARAMETERS

    def __init__(self, delay: float = 0.0, rate: float | None = None, time_constant: float | None = None,
                 tension_slack: float | None = None, offsets: Sequence[float] = ()) -> None:
        offsets = tuple(float(o) for o in offsets) or (0.0,) * 24
        if len(offsets) != 24:
            raise ParameterError(f"MeasuredActuator.offsets must hold 24 values [m] (one per cable), got "
                                 f"{len(offsets)}.")
        form = LawForm(delay=delay > 0, rate_limit=rate is not None, lag=time_constant is not None,
                       tension_limit=tension_slack is not None)
        self.law = ActuatorLaw(form=form, delay=float(delay), rate=math.inf if rate is None else float(rate),
                               time_constant=0.0 if time_constant is None else float(time_constant),
                               tension_slack=math.inf if tension_slack is None else float(tension_slack),
                               offsets=offsets)

    @classmethod
    def from_fit(cls, fit: ActuatorFit) -> MeasuredActuator:
        """The law of an actuator stage's fit, with the offsets of the cables it reported (the others 0)."""
        if fit.law is None:
            raise ParameterError("the actuator stage fitted no law (see its findings); nothing to put in the model.")
        law = fit.law
        offsets = np.zeros(24)
        for j in fit.offset_cables:
            offsets[j] = float(fit.offsets[j])
        return cls(delay=law.delay if law.form.delay else 0.0, rate=law.rate if law.form.rate_limit else None,
                   time_constant=law.time_constant if law.form.lag else None,
                   tension_slack=law.tension_slack if law.form.tension_limit else None, offsets=offsets.tolist())

    def parameters(self) -> tuple[Parameter, ...]:
        return ()

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.command_delay += self.law.delay
        setup.actuator = LawActuator(self.law, np.asarray(self.law.offsets), float(params["stiffnessActive"]),
                                     setup.gains, setup.dt)

    def config(self) -> dict:
        law = self.law
        return {"effect": self.name, "delay": law.delay,
                "rate": law.rate if law.form.rate_limit else None,
                "time_constant": law.time_constant if law.form.lag else None,
                "tension_slack": law.tension_slack if law.form.tension_limit else None,
                "offsets": list(law.offsets)}
