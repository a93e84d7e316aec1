"""A tension-limited rate actuator (NTRT's basic actuator) in place of the motor model.

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

import numpy as np
from numba import njit

from physics.actuators import MotorGains
from physics.cables import cable_tensions
from physics.effects.base import Effect, ModelSetup
from physics.errors import ParameterError
from physics.parameters import Parameter

__all__ = ["tension_limited_step", "TensionLimitedActuator", "TensionLimitedActuation"]


@njit(cache=True)
def tension_limited_step(rest: np.ndarray, speed: np.ndarray, target: np.ndarray, tension: np.ndarray,
                         rate: float, max_tension: float, stiffness: float, min_rest: float, dt: float) -> None:
    """Advance rest lengths (24,) [m] in place by one step of the module docstring's law; speed
    (24,) gets the rest-length rate [m/s]; tension (24,) [N] is the cables' present tension."""
    step = rate * dt
    for j in range(rest.shape[0]):
        goal = target[j]
        floor = rest[j] + (tension[j] - max_tension) / stiffness
        if floor > goal:
            goal = floor
        d = goal - rest[j]
        if d > step:
            d = step
        elif d < -step:
            d = -step
        r = rest[j] + d
        if r < min_rest:
            r = min_rest
        speed[j] = (r - rest[j]) / dt
        rest[j] = r


@njit(cache=True)
def _follow(lengths: np.ndarray, rates: np.ndarray, targets: np.ndarray, rest0: np.ndarray, substeps: int,
            law: tuple, limits: tuple, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Rest lengths and speeds (T x m) of the actuator driven along observed cable lengths and rates
    (T x m; lengths linear between samples, rates constant per interval), one target row per
    physics step; limits = (rate, maxTens, k, L0_min)."""
    n, m = lengths.shape
    rest, speed = rest0.copy(), np.zeros(m)
    tension, now = np.empty(m), np.empty(m)
    rest_out, speed_out = np.empty((n, m)), np.empty((n, m))
    for i in range(n):
        rest_out[i] = rest
        speed_out[i] = speed
        if i == n - 1:
            break
        for s in range(substeps):
            w = (s + 0.5) / substeps
            for j in range(m):
                now[j] = (1.0 - w) * lengths[i, j] + w * lengths[i + 1, j]
            cable_tensions(now, rates[i], rest, law[0], law[1], law[2], law[3], tension)
            tension_limited_step(rest, speed, targets[i * substeps + s], tension, limits[0], limits[1],
                                 limits[2], limits[3], dt)
    return rest_out, speed_out


class TensionLimitedActuator:
    """The actuator of the module docstring at speed ``rate`` [m/s], limit ``max_tension`` [N] and
    cable stiffness ``stiffness`` [N/m] (physics.actuators.Actuator)."""

    def __init__(self, rate: float, max_tension: float, stiffness: float, gains: MotorGains, dt: float) -> None:
        for name, value in (("rate", rate), ("max_tension", max_tension), ("stiffness", stiffness)):
            if not (np.isfinite(value) and value > 0):
                raise ParameterError(f"TensionLimitedActuator.{name} must be > 0, got {value!r}.")
        self.rate, self.max_tension, self.stiffness = float(rate), float(max_tension), float(stiffness)
        self._min, self._dt = gains.min_rest_length, float(dt)

    def step(self, rest: np.ndarray, speed: np.ndarray, target: np.ndarray, tension: np.ndarray) -> None:
        tension_limited_step(rest, speed, target, tension, self.rate, self.max_tension, self.stiffness, self._min,
                             self._dt)

    def follow(self, lengths: np.ndarray, rates: np.ndarray, targets: np.ndarray, rest0: np.ndarray,
               substeps: int, law: tuple) -> tuple[np.ndarray, np.ndarray]:
        limits = (self.rate, self.max_tension, self.stiffness, self._min)
        return _follow(lengths, rates, targets, rest0, substeps, law, limits, self._dt)

    def speed_from_rest(self, rate: np.ndarray) -> np.ndarray:
        """Its speed state is the rest-length rate itself [m/s]."""
        return np.asarray(rate, float).copy()


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
