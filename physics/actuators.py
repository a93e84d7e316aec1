"""Motor actuators that wind the cables: the rest length L0 follows a commanded target.

Each of the 24 cables has a spool of radius r on a motor of inertia J and viscous friction b
(NTRT ``tgKinematicActuator``, NASA-Tensegrity-Robotics-Toolkit/NTRTsim). Per step of length dt:

    ω_d   = clip(-K_p (L0 - L_pref), ±v_max) / r          desired spool speed [rad/s]
    τ_d   = K_v (ω_d - ω)                                  motor-driver torque command [N m]
    τ_max = max(0, T_max r (1 - r|ω| / v_max))             torque-speed limit (stall at T_max)
    τ     = clip(τ_d, ±τ_max)
    ω'    = ω + dt (τ - b ω + T r) / J,   |ω'| <= v_max / r
    ω'    = 0 if τ ω' <= 0                                 not back-drivable: the cable tension T
                                                          never unwinds the spool by itself
    L0'   = max(L0 + r ω' dt, L0_min)

with T_max = maxTens, v_max = targetVelocity, r = motor_radius, b = motor_friction,
J = motor_inertia. K_p [1/s] and K_v [N m s] are the gains of the motor driver (fixed firmware,
not identified). Positive ω pays cable out (lengthens L0).

Encoders. The robot's firmware knows rest lengths only through spool encoders zeroed at assembly
against the design rest length L0_zero (nominal robot). A command L_pref_cmd therefore means the
true target L_pref = L_pref_cmd + (L0_build - L0_zero), and the reported ``rest_length`` is
L0 - (L0_build - L0_zero). On the nominal robot the two coincide; on another θ the build rest
length L0_build = L_build - pretension / k shifts every target, which is how pretension and the
geometry keep acting after the robot was assembled.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numba import njit

from physics.actuator_laws import ActuatorLaw, interval_step
from physics.cables import cable_tensions
from physics.errors import ParameterError

__all__ = ["MotorGains", "motor_step", "rate_limited_step", "tension_limited_step", "law_step", "Actuator",
           "MotorActuator", "RateLimitedActuator", "TensionLimitedActuator", "LawActuator"]


@dataclass(frozen=True)
class MotorGains:
    """Gains of the motor driver: position gain ``kp`` [1/s], speed gain ``kv`` [N m s], floor
    ``min_rest_length`` [m]."""

    kp: float = 10.0
    kv: float = 0.05
    min_rest_length: float = 0.01

    def __post_init__(self) -> None:
        for name in ("kp", "kv", "min_rest_length"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ParameterError(f"MotorGains.{name} must be a positive finite number, got {value!r}.")


@njit(cache=True)
def motor_step(rest: np.ndarray, speed: np.ndarray, target: np.ndarray, tension: np.ndarray,
               max_tension: float, max_velocity: float, radius: float, friction: float,
               inertia: float, kp: float, kv: float, min_rest: float, dt: float) -> None:
    """Advance rest lengths ``rest`` (24,) [m] and spool speeds ``speed`` (24,) [rad/s] in place by dt."""
    omega_max = max_velocity / radius
    for j in range(rest.shape[0]):
        w = speed[j]
        v_d = -kp * (rest[j] - target[j])
        if v_d > max_velocity:
            v_d = max_velocity
        elif v_d < -max_velocity:
            v_d = -max_velocity
        tau = kv * (v_d / radius - w)
        tau_max = max_tension * radius * (1.0 - radius * abs(w) / max_velocity)
        if tau_max < 0.0:
            tau_max = 0.0
        if tau > tau_max:
            tau = tau_max
        elif tau < -tau_max:
            tau = -tau_max
        w = w + dt * (tau - friction * w + tension[j] * radius) / inertia
        if w > omega_max:
            w = omega_max
        elif w < -omega_max:
            w = -omega_max
        if tau * w <= 0.0:
            w = 0.0
        speed[j] = w
        r = rest[j] + radius * w * dt
        rest[j] = r if r > min_rest else min_rest


@njit(cache=True)
def rate_limited_step(rest: np.ndarray, speed: np.ndarray, target: np.ndarray, rate: float,
                      min_rest: float, dt: float) -> None:
    """Move each rest length toward its target at the fixed speed ``rate`` [m/s]:
    L0' = max(L0 + clip(L_pref - L0, ±rate dt), L0_min); speed (24,) gets the rate of change [m/s]."""
    step = rate * dt
    for j in range(rest.shape[0]):
        d = target[j] - rest[j]
        if d > step:
            d = step
        elif d < -step:
            d = -step
        r = rest[j] + d
        rest[j] = r if r > min_rest else min_rest
        speed[j] = d / dt


@njit(cache=True)
def tension_limited_step(rest: np.ndarray, speed: np.ndarray, target: np.ndarray, tension: np.ndarray,
                         rate: float, max_tension: float, stiffness: float, min_rest: float, dt: float) -> None:
    """NTRT's basic actuator: move each rest length toward its target at ``rate`` [m/s], but never
    wind a cable past ``max_tension`` [N] (cable ``stiffness`` k [N/m]):
    floor = L0 + (T - maxTens) / k, goal = max(L_pref, floor), L0' = max(L0 + clip(goal - L0,
    ±rate dt), L0_min). Rest lengths (24,) [m] change in place; speed (24,) gets the rate of change
    [m/s]; tension (24,) [N] is the cables' present tension (physics.effects.actuation)."""
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
def law_step(rest: np.ndarray, speed: np.ndarray, target: np.ndarray, tension: np.ndarray, rate: float, tau: float,
             slack: float, stiffness: float, min_rest: float, dt: float) -> None:
    """One physics step dt [s] of an actuator law read from the encoders (physics.actuator_laws):
    the motor acts on u = max(L_pref, L0 + T / k - s), the stretch T / k standing for the observed
    cable length less L0 (s = inf: no tension limit); v ramps toward u at up to ``rate`` [m/s]
    (inf: at once) and L0 follows v through the lag τ = ``tau`` [s] (0: L0 = v), both integrated
    exactly over dt (physics.actuator_laws.interval_step). ``speed`` (24,) holds dL0/dt [m/s], which
    with a lag is (v - L0) / τ, so v = L0 + τ dL0/dt is rebuilt from it; rest and speed change in place."""
    for j in range(rest.shape[0]):
        u = target[j]
        floor = rest[j] + tension[j] / stiffness - slack
        if floor > u:
            u = floor
        before = rest[j]
        v = before + tau * speed[j] if tau > 0.0 else before
        v, lag = interval_step(v, before, u, rate, tau, dt)
        after = lag if lag > min_rest else min_rest
        rest[j] = after
        speed[j] = (v - after) / tau if tau > 0.0 else (after - before) / dt


_MOTOR, _RATE_LIMITED, _TENSION_LIMITED, _LAW = 0, 1, 2, 3


@njit(cache=True)
def _follow(kind: int, lengths: np.ndarray, rates: np.ndarray, targets: np.ndarray, rest0: np.ndarray,
            substeps: int, law: tuple, motor: tuple, rate: float, min_rest: float,
            dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Rest lengths and speeds (T x m each) of an actuator (``kind``) driven along observed cable
    lengths and rates (T x m; lengths linear between samples, rates constant per interval), one
    target row per physics step (substeps (T - 1) x m), tensions from physics.cables.cable_tensions;
    ``motor`` holds the motor model's arguments (kind _MOTOR), or first (maxTens, stiffness)
    (_TENSION_LIMITED) or (slack, stiffness, tau) (_LAW)."""
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
            target = targets[i * substeps + s]
            if kind == _RATE_LIMITED:
                rate_limited_step(rest, speed, target, rate, min_rest, dt)
                continue
            w = (s + 0.5) / substeps
            for j in range(m):
                now[j] = (1.0 - w) * lengths[i, j] + w * lengths[i + 1, j]
            cable_tensions(now, rates[i], rest, law[0], law[1], law[2], law[3], tension)
            if kind == _TENSION_LIMITED:      # motor = (maxTens, stiffness, ...)
                tension_limited_step(rest, speed, target, tension, rate, motor[0], motor[1], min_rest, dt)
                continue
            if kind == _LAW:                  # motor = (slack, stiffness, tau, ...)
                law_step(rest, speed, target, tension, rate, motor[2], motor[0], motor[1], min_rest, dt)
                continue
            motor_step(rest, speed, target, tension, motor[0], motor[1], motor[2], motor[3], motor[4], motor[5],
                       motor[6], motor[7], motor[8])
    return rest_out, speed_out


@runtime_checkable
class Actuator(Protocol):
    """The component that moves rest lengths toward targets, one physics step at a time.

    ``step(rest, speed, target, tension)`` updates rest lengths (24,) [m] and the actuator's speed
    state (24,) in place from the targets (24,) [m] and the cable tensions (24,) [N];
    ``follow(lengths, rates, targets, rest0, substeps, law)`` runs it along an observed cable
    motion (the predictor's reconstruction, :func:`_follow`); ``speed_from_rest(rate)`` turns a
    rest-length rate [m/s] into its speed state (for states rebuilt from measured rest lengths)."""

    def step(self, rest: np.ndarray, speed: np.ndarray, target: np.ndarray, tension: np.ndarray) -> None: ...

    def follow(self, lengths: np.ndarray, rates: np.ndarray, targets: np.ndarray, rest0: np.ndarray,
               substeps: int, law: tuple) -> tuple[np.ndarray, np.ndarray]: ...

    def speed_from_rest(self, rate: np.ndarray) -> np.ndarray: ...


class MotorActuator:
    """The motor model of this module (spool, driver gains, torque-speed limit) at θ's motor parameters."""

    def __init__(self, params: Mapping[str, float], gains: MotorGains, dt: float) -> None:
        self.radius = float(params["motor_radius"])
        self._args = (params["maxTens"], params["targetVelocity"], params["motor_radius"], params["motor_friction"],
                      params["motor_inertia"], gains.kp, gains.kv, gains.min_rest_length, dt)

    def step(self, rest: np.ndarray, speed: np.ndarray, target: np.ndarray, tension: np.ndarray) -> None:
        motor_step(rest, speed, target, tension, *self._args)

    def follow(self, lengths: np.ndarray, rates: np.ndarray, targets: np.ndarray, rest0: np.ndarray,
               substeps: int, law: tuple) -> tuple[np.ndarray, np.ndarray]:
        return _follow(_MOTOR, lengths, rates, targets, rest0, substeps, law, self._args, 1.0, self._args[7],
                       self._args[8])

    def speed_from_rest(self, rate: np.ndarray) -> np.ndarray:
        """Spool speed ω = (dL0/dt) / r [rad/s]."""
        return rate / self.radius


class RateLimitedActuator:
    """An ideal actuator: the rest length follows the target at ``rate`` [m/s], no motor dynamics."""

    def __init__(self, rate: float, gains: MotorGains, dt: float) -> None:
        if not (np.isfinite(rate) and rate > 0):
            raise ParameterError(f"the actuator rate must be > 0 m/s, got {rate!r}.")
        self.rate, self._min, self._dt = float(rate), gains.min_rest_length, dt

    def step(self, rest: np.ndarray, speed: np.ndarray, target: np.ndarray, tension: np.ndarray) -> None:
        rate_limited_step(rest, speed, target, self.rate, self._min, self._dt)

    def follow(self, lengths: np.ndarray, rates: np.ndarray, targets: np.ndarray, rest0: np.ndarray,
               substeps: int, law: tuple) -> tuple[np.ndarray, np.ndarray]:
        motor = (1.0,) * 9   # unused by this kind
        return _follow(_RATE_LIMITED, lengths, rates, targets, rest0, substeps, law, motor, self.rate, self._min,
                       self._dt)

    def speed_from_rest(self, rate: np.ndarray) -> np.ndarray:
        return np.asarray(rate, float).copy()


class TensionLimitedActuator:
    """NTRT's basic actuator (:func:`tension_limited_step`) at speed ``rate`` [m/s], limit
    ``max_tension`` [N] and cable stiffness ``stiffness`` [N/m]."""

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
        limits = (self.max_tension, self.stiffness) + (1.0,) * 7     # the rest unused by this kind
        return _follow(_TENSION_LIMITED, lengths, rates, targets, rest0, substeps, law, limits, self.rate, self._min,
                       self._dt)

    def speed_from_rest(self, rate: np.ndarray) -> np.ndarray:
        """Its speed state is the rest-length rate itself [m/s]."""
        return np.asarray(rate, float).copy()


class LawActuator:
    """An actuator law read from the encoders (physics.actuator_readings) as the model's actuator
    (:func:`law_step`): its rate, lag and tension slack, per-cable offsets (24,) [m] added to every
    target (the readings settle that far off the command), the cables' ``stiffness`` k [N/m] to turn
    tension into stretch. Its delay is the model's command delay (physics.effects.MeasuredActuator)."""

    def __init__(self, law: ActuatorLaw, offsets: np.ndarray, stiffness: float, gains: MotorGains, dt: float) -> None:
        offsets = np.asarray(offsets, float)
        if offsets.shape != (24,) or not np.all(np.isfinite(offsets)):
            raise ParameterError(f"LawActuator needs 24 finite offsets [m], got shape {offsets.shape}.")
        if not (np.isfinite(stiffness) and stiffness > 0):
            raise ParameterError(f"LawActuator.stiffness must be > 0 N/m, got {stiffness!r}.")
        self.law, self.offsets, self.stiffness = law, offsets, float(stiffness)
        self._min, self._dt = gains.min_rest_length, float(dt)
        self._args = (float(law.rate), float(law.time_constant), float(law.tension_slack), self.stiffness)

    def step(self, rest: np.ndarray, speed: np.ndarray, target: np.ndarray, tension: np.ndarray) -> None:
        rate, tau, slack, k = self._args
        law_step(rest, speed, target + self.offsets, tension, rate, tau, slack, k, self._min, self._dt)

    def follow(self, lengths: np.ndarray, rates: np.ndarray, targets: np.ndarray, rest0: np.ndarray,
               substeps: int, law: tuple) -> tuple[np.ndarray, np.ndarray]:
        rate, tau, slack, k = self._args
        parts = (slack, k, tau) + (1.0,) * 6     # the rest unused by this kind
        return _follow(_LAW, lengths, rates, np.ascontiguousarray(targets + self.offsets), rest0, substeps, law,
                       parts, rate, self._min, self._dt)

    def speed_from_rest(self, rate: np.ndarray) -> np.ndarray:
        """Its speed state is the rest-length rate itself [m/s]."""
        return np.asarray(rate, float).copy()
