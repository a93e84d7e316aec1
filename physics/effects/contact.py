"""Rolling resistance: a torque that resists a rod's rotation while its caps touch the ground.

DART's contact has Coulomb friction against sliding but nothing against rolling or pivoting: a
rod whose cap rests on the ground turns about the contact freely. Many engines (Bullet's and
MuJoCo's rolling friction) and real end caps (rubber that deforms under load) resist that turn
with a torque up to μ_r N about the axes in the ground plane, μ_r [m] the rolling-resistance
lever arm and N [N] the normal load. For rod i with a cap in contact (node within ``band`` of
the cap radius above the ground plane, normal n̂), angular velocity ω_i, mass m_i (its point
masses included), applied force F_i (cables and every other effect, gravity and contact
excluded) and P the projection onto the ground plane:

    ω⊥ = P ω_i,    N_i = max(0, −(F_i + m_i g)·n̂),
    τ_stop = −(P I_i⁻¹ P)⁺ ω⊥ / dt,    τ_i = τ_stop · min(1, μ_r N_i / |τ_stop|)

N_i is the rod's quasi-static load on the ground: the normal force that balances what pushes the
rod into it (the model reads no contact forces back from DART; the rod's own acceleration is left
out). A cable that lifts the rod lightens it, one that pulls it down loads it. I_i is the inertia
tensor of the bare rod (transverse I_t, axial I_a about its axis â; point masses left out) and dt
the physics step. τ_stop is the torque in the ground plane that stops ω⊥ in one step of the free
rod, so the resistance brakes a turn to rest and holds it (as static rolling friction does) but
never reverses it, about the rod's own axis too (where I_a ≪ I_t). τ_i · ω_i = τ_i · ω⊥ ≤ 0: the
effect removes energy, never adds it. μ_r = 0 is the T6 without it.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit

from physics.cables import node_kinematics
from physics.effects.base import Effect, ModelSetup
from physics.errors import ParameterError
from physics.geometry import rod_mass_properties
from physics.parameters import Parameter

__all__ = ["RollingResistance", "rolling_torques"]


@njit(cache=True)
def _plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (3,) spanning the plane normal to ``normal`` (unit)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(normal, helper)
    e1 /= np.sqrt(e1 @ e1)
    return e1, np.cross(normal, e1)


@njit(cache=True)
def rolling_torques(positions: np.ndarray, velocities: np.ndarray, half_length: float, normal: np.ndarray,
                    contact_height: float, masses: np.ndarray, gravity: np.ndarray, lever: float,
                    inertia: np.ndarray, dt: float, out: np.ndarray) -> None:
    """Add τ_i (module docstring) to the FreeJoint generalised forces ``out`` (36,) [N m in 6i..6i+2],
    whose force parts (6i+3..6i+5) hold the rods' applied forces F_i [N].

    positions, velocities: FreeJoint q, dq (36,); normal (3,): the ground's unit normal;
    contact_height [m]: a node lower than this above the plane touches it; masses (6,) [kg];
    gravity (3,) [m/s²]; lever: μ_r [m]; inertia: (I_t, I_a) [kg m²]; dt [s]."""
    nodes, _, axes = node_kinematics(positions, velocities, np.full(6, half_length))
    touching = np.zeros(6, dtype=np.bool_)
    for n in range(12):
        if nodes[n] @ normal < contact_height:
            touching[n // 2] = True
    e1, e2 = _plane_basis(normal)
    c = inertia[0] / inertia[1] - 1.0
    for i in range(6):
        if not touching[i]:
            continue
        load = -(out[6 * i + 3:6 * i + 6] + masses[i] * gravity) @ normal
        if load <= 0.0:
            continue
        w = velocities[6 * i:6 * i + 3]
        w1, w2 = w @ e1, w @ e2
        a1, a2 = axes[i] @ e1, axes[i] @ e2
        shrink = c * (a1 * w1 + a2 * w2) / (1.0 + c * (a1 * a1 + a2 * a2))     # Sherman-Morrison
        s1, s2 = inertia[0] * (w1 - shrink * a1) / dt, inertia[0] * (w2 - shrink * a2) / dt
        size = np.sqrt(s1 * s1 + s2 * s2)
        if size < 1e-12:
            continue
        scale = min(1.0, lever * load / size)
        out[6 * i:6 * i + 3] -= scale * (s1 * e1 + s2 * e2)


class RollingResistance(Effect):
    """Rolling resistance of the caps on the ground (module docstring): a torque up to
    ``rolling_resistance`` × N against a touching rod's rotation about axes in the ground plane."""

    name = "rolling_resistance"
    description = "rolling resistance of the caps on the ground"

    def __init__(self, band: float = 0.005) -> None:
        if not (np.isfinite(band) and band > 0):
            raise ParameterError(f"RollingResistance.band must be > 0 m, got {band!r}.")
        self.band = float(band)

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("rolling_resistance", "m", 0.0, 0.0, 1.0,
                          "rolling-resistance lever arm of a cap on the ground", strict=False),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        lever = float(values["rolling_resistance"])
        if lever <= 0:
            return
        mp = rod_mass_properties(params["density"], params["radius"], params["density_mp"], params["radius_mp"],
                                 params["rod_length"], params["rod_length_mp"])
        half, band = 0.5 * float(params["rod_length"]), self.band
        inertia = np.array([mp.transverse, mp.axial])

        masses = np.empty(0)

        def term(q: np.ndarray, dq: np.ndarray, out: np.ndarray) -> None:
            nonlocal masses    # read when stepping, after every effect has edited the setup (point masses)
            if masses.size == 0:
                masses = np.full(6, mp.mass)
                for rod, mass, _ in setup.point_masses:
                    masses[rod] += mass
            rolling_torques(q, dq, half, setup.ground_normal, setup.cap_radius + band, masses, setup.gravity, lever,
                            inertia, setup.dt, out)

        setup.contact_terms.append(term)

    def config(self) -> dict:
        return {"effect": self.name, "band": self.band}
