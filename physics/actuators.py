"""Motor actuators that wind the cables: the rest length L0 follows a commanded target.

Each of the 24 cables has a spool of radius r on a motor of inertia J and viscous friction b
(NTRT ``tgKinematicActuator``; shared/reference/t6-superball.md). Per step of length dt:

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

from dataclasses import dataclass

import numpy as np
from numba import njit

from physics.errors import ParameterError

__all__ = ["MotorGains", "motor_step"]


@dataclass(frozen=True)
class MotorGains:
    """Gains of the motor driver: position gain ``kp`` [1/s], speed gain ``kv`` [N m s], floor ``min_rest_length`` [m]."""

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
