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
"""
from __future__ import annotations

from collections.abc import Mapping

from physics.actuators import TensionLimitedActuator
from physics.effects.base import Effect, ModelSetup
from physics.parameters import Parameter

__all__ = ["TensionLimitedActuation"]


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
