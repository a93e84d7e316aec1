"""Effects that add forces each physics step: quadratic and viscous (linear) drag, viscous ground
friction.

All act on the nodes (rod ends): a rod's drag is lumped on its two ends."""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit

from physics.effects.base import Effect, ModelSetup
from physics.errors import ParameterError
from physics.parameters import Parameter

__all__ = ["AirDrag", "ViscousDrag", "GroundViscosity", "drag_forces", "viscous_drag_forces", "viscous_ground_forces"]


@njit(cache=True)
def drag_forces(velocities: np.ndarray, coefficient: float, out: np.ndarray) -> None:
    """out[n] += -c |v_n| v_n for the 12 nodes (quadratic drag, c [N s²/m²])."""
    for n in range(velocities.shape[0]):
        vx, vy, vz = velocities[n, 0], velocities[n, 1], velocities[n, 2]
        speed = np.sqrt(vx * vx + vy * vy + vz * vz)
        out[n, 0] -= coefficient * speed * vx
        out[n, 1] -= coefficient * speed * vy
        out[n, 2] -= coefficient * speed * vz


@njit(cache=True)
def viscous_drag_forces(velocities: np.ndarray, coefficient: float, out: np.ndarray) -> None:
    """out[n] += -c v_n for the 12 nodes (linear drag, c [N s/m])."""
    for n in range(velocities.shape[0]):
        for k in range(3):
            out[n, k] -= coefficient * velocities[n, k]


@njit(cache=True)
def viscous_ground_forces(nodes: np.ndarray, velocities: np.ndarray, coefficient: float,
                          contact_height: float, out: np.ndarray) -> None:
    """out[n, :2] += -c v_n,xy for nodes lower than ``contact_height`` [m] (caps on the ground)."""
    for n in range(nodes.shape[0]):
        if nodes[n, 2] < contact_height:
            out[n, 0] -= coefficient * velocities[n, 0]
            out[n, 1] -= coefficient * velocities[n, 1]


class AirDrag(Effect):
    """Quadratic air drag on the rods, lumped on their ends: F_n = -drag |v_n| v_n [N]."""

    name = "air_drag"
    description = "quadratic air drag on the rods"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("drag", "N*s^2/m^2", 0.0, 0.0, 20.0, "drag coefficient per rod end", strict=False),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        c = float(values["drag"])
        if c > 0:
            setup.force_terms.append(lambda p, v, out: drag_forces(v, c, out))


class ViscousDrag(Effect):
    """Linear drag on the rods, lumped on their ends: F_n = -viscous_drag v_n [N].

    The law of slow flow around a rod and of the velocity damping many engines apply to every
    body (a per-step factor (1 - d)^dt on v is, for small d, this force with c = m d / 2 per end
    of a rod of mass m). :class:`AirDrag` is the quadratic law of fast flow."""

    name = "viscous_drag"
    description = "linear (viscous) drag on the rods"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("viscous_drag", "N*s/m", 0.0, 0.0, 20.0, "linear drag coefficient per rod end",
                          strict=False),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        c = float(values["viscous_drag"])
        if c > 0:
            setup.force_terms.append(lambda p, v, out: viscous_drag_forces(v, c, out))


class GroundViscosity(Effect):
    """Rolling resistance as viscous ground friction: a cap within ``band`` [m] of the ground
    feels F_xy = -ground_viscosity v_xy [N] on top of Coulomb friction."""

    name = "ground_viscosity"
    description = "viscous ground friction (rolling resistance) on caps in contact"

    def __init__(self, band: float = 0.005) -> None:
        if not (np.isfinite(band) and band > 0):
            raise ParameterError(f"GroundViscosity.band must be > 0 m, got {band!r}.")
        self.band = float(band)

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("ground_viscosity", "N*s/m", 0.0, 0.0, 300.0, "viscous friction of a cap on the ground",
                          strict=False),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        c = float(values["ground_viscosity"])
        if c > 0:   # the contact height is read at each step: another effect may change the cap radius
            setup.force_terms.append(
                lambda p, v, out: viscous_ground_forces(p, v, c, setup.cap_radius + self.band, out))

    def config(self) -> dict:
        return {"effect": self.name, "band": self.band}
