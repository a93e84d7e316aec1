"""Options of the T6 model that are not identified parameters, and its full simulator state."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from physics.actuators import MotorGains
from physics.errors import ParameterError
from physics.geometry import closed_faces

__all__ = ["ModelOptions", "RobotState"]

_FACES = closed_faces()


@dataclass(frozen=True)
class ModelOptions:
    """Options of the T6 model that are not identified parameters.

    dt: physics step [s]; gravity [m/s^2] (0 switches it off); ground: whether the ground exists;
    friction: Coulomb coefficient rod-ground; spin_damping: axial damper of each rod [N m s]
    (see physics.cables; applied semi-implicitly, c / (1 + c dt / I_axial), so it is stable for
    any value; 2.0 stops a spin within ~5 ms, which keeps the unobservable spin small);
    drop_height: gap between the lowest cap and the ground at build [m];
    face: which of the 8 closed faces faces the ground at build (0..7); max_speed: a node faster
    than this [m/s] means the simulation diverged; motor: gains of the motor drivers.

    The two constants with a mass in their unit, ``spin_damping`` and ``motor.kv`` [N m s], are the
    values for the nominal robot: a model applies them times its mass scale
    s(θ) = M_rods(θ) / M_rods(θ_nominal) (:func:`physics.scaling.rod_mass_scale`;
    :meth:`spin_damping_at`, :meth:`motor_at`), so that every mass and force times λ leaves the
    motion unchanged (physics.scaling) and no fixed constant tells the data the robot's absolute mass.
    """

    dt: float = 1e-3
    gravity: float = 9.81
    ground: bool = True
    friction: float = 0.5
    spin_damping: float = 2.0
    drop_height: float = 0.02
    face: int = 0
    max_speed: float = 30.0
    motor: MotorGains = field(default_factory=MotorGains)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.dt) and 0 < self.dt <= 0.01):
            raise ParameterError(f"ModelOptions.dt must be in (0, 0.01] s, got {self.dt!r}; the default is 0.001 s.")
        for name in ("gravity", "friction", "spin_damping", "drop_height"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ParameterError(f"ModelOptions.{name} must be a finite number >= 0, got {value!r}.")
        if not (np.isfinite(self.max_speed) and self.max_speed > 0):
            raise ParameterError(f"ModelOptions.max_speed must be > 0 m/s, got {self.max_speed!r}.")
        if self.face not in range(len(_FACES)):
            raise ParameterError(f"ModelOptions.face must be an integer in 0..{len(_FACES) - 1}, got {self.face!r}.")
        if not isinstance(self.motor, MotorGains):
            raise ParameterError(f"ModelOptions.motor must be a MotorGains, got {type(self.motor).__name__}.")

    def spin_damping_at(self, mass_scale: float) -> float:
        """The axial spin damping applied to a robot of mass scale s [N m s]: c_spin s."""
        return self.spin_damping * _checked_scale(mass_scale)

    def motor_at(self, mass_scale: float) -> MotorGains:
        """The motor-driver gains applied to a robot of mass scale s: K_v s [N m s]; K_p [1/s] and the
        rest-length floor [m] have no mass in their unit and stay."""
        return replace(self.motor, kv=self.motor.kv * _checked_scale(mass_scale))


def _checked_scale(mass_scale: float) -> float:
    if not (np.isfinite(mass_scale) and mass_scale > 0):
        raise ParameterError(f"the mass scale s = M(θ) / M(θ_nominal) must be finite and > 0, got {mass_scale!r}.")
    return float(mass_scale)


@dataclass(frozen=True)
class RobotState:
    """Full simulator state: FreeJoint positions/velocities (36 each), true rest lengths and spool
    speeds (24 each), commanded true targets (24), and time [s]."""

    positions: np.ndarray
    velocities: np.ndarray
    rest_length: np.ndarray
    motor_speed: np.ndarray
    target: np.ndarray
    time: float
