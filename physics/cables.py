"""Cable forces of the tensegrity: spring-dampers that never push (the per-step hot path).

For cable j between nodes a and b (anchors on the rod axis at the nodes):

    L = |p_b - p_a|,  u = (p_b - p_a)/L,  dL/dt = (v_b - v_a)·u
    s = L - L0,  k_eff = k (1 + h (1 + tanh((dL/dt) / v_h)) / 2)   (h: hysteresis: k (1 + h) while
                                                 lengthening, k while shortening; v_h = 0.01 m/s
                                                 smooths the switch so the law stays continuous)
    F_k = max(0, k_eff s (1 + β s)),  F_d = c dL/dt,  F_d clipped to ±F_k
    F = F_k + F_d  if s > 0  else 0             (so 0 <= F <= 2 F_k: a cable never pushes)

h = 0 and β = 0 (the :class:`CableLaw` defaults) give NTRT's linear spring-damper; the effects
``CableHysteresis`` and ``NonlinearStiffness`` (physics.effects) set them. :func:`cable_tension`
is the one place the law is written: the simulation (:func:`cable_wrenches`) and the one-step
predictor's actuator reconstruction (physics.predictor) both call it.

node a receives +F u, node b receives -F u (NTRT ``tgSpringCable``, NASA-Tensegrity-Robotics-Toolkit/NTRTsim).

Each rod is one FreeJoint body whose origin is its centre of mass and whose local z axis is the
rod axis; nodes are c ± h·a with a the rod axis in world coordinates. The wrench on rod i is
written as FreeJoint generalised forces [world torque about the centre (3), world force (3)],
which is what ``Skeleton.setForces`` expects (checked against ``BodyNode.addExtForce`` in
tests/physics/test_cables.py).

Anchors on the axis let nothing resist a rod spinning about its own axis, so a rod resting on
its spherical end caps could roll like a wheel for ever. A small axial damper
τ = -c_spin (ω·a) a stands in for the spin resistance of real cable attachments (which sit off
the axis, on the end caps) and for rolling friction (NTRT: 0.01); its coefficient is a model
option, not an identified parameter.

The kernels are compiled with numba: a vectorised numpy version cost more per step than the
DART step itself; benchmarks/physics_speed.py shows what the whole step costs now.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = ["CableLaw", "cable_tension", "cable_tensions", "rod_axes", "node_kinematics", "cable_wrenches",
           "add_node_forces", "cable_energy"]


#: Rate scale v_h [m/s] of the smooth switch between shortening and lengthening stiffness.
HYSTERESIS_RATE = 0.01


@dataclass(frozen=True)
class CableLaw:
    """Coefficients of the cable force law: stiffness k [N/m], damping c [N s/m], quadratic
    stiffness β [1/m] (F_k = k s (1 + β s)) and hysteresis h [-] (k (1 + h) while lengthening)."""

    stiffness: float
    damping: float
    quadratic: float = 0.0
    hysteresis: float = 0.0

    def args(self) -> tuple[float, float, float, float]:
        """(k, c, β, h), the positional arguments of the kernels."""
        return (self.stiffness, self.damping, self.quadratic, self.hysteresis)


@njit(cache=True)
def cable_tension(stretch: float, rate: float, stiffness: float, damping: float,
                  quadratic: float, hysteresis: float) -> float:
    """Tension F >= 0 [N] of one cable from its stretch s = L - L0 [m] and rate dL/dt [m/s]."""
    if stretch <= 0.0:
        return 0.0
    k = stiffness
    if hysteresis != 0.0:
        k = stiffness * (1.0 + hysteresis * 0.5 * (1.0 + np.tanh(rate / HYSTERESIS_RATE)))
    f_k = k * stretch * (1.0 + quadratic * stretch)
    if f_k <= 0.0:
        return 0.0
    f_d = damping * rate
    if f_d > f_k:
        f_d = f_k
    elif f_d < -f_k:
        f_d = -f_k
    return f_k + f_d


@njit(cache=True)
def cable_tensions(lengths: np.ndarray, rates: np.ndarray, rest_lengths: np.ndarray, stiffness: float,
                   damping: float, quadratic: float, hysteresis: float, out: np.ndarray) -> None:
    """Tensions (m,) of m cables from lengths, rates and rest lengths (m,) each, written into ``out``."""
    for j in range(lengths.shape[0]):
        out[j] = cable_tension(lengths[j] - rest_lengths[j], rates[j], stiffness, damping, quadratic, hysteresis)


@njit(cache=True, fastmath=False)
def rod_axes(positions: np.ndarray) -> np.ndarray:
    """Rod axes a_i = R(w_i) e_z from FreeJoint positions (36,) → (6 x 3) unit vectors."""
    axes = np.empty((6, 3))
    for i in range(6):
        wx, wy, wz = positions[6 * i], positions[6 * i + 1], positions[6 * i + 2]
        angle = np.sqrt(wx * wx + wy * wy + wz * wz)
        if angle < 1e-12:
            axes[i, 0] = wy
            axes[i, 1] = -wx
            axes[i, 2] = 1.0
            continue
        kx, ky, kz = wx / angle, wy / angle, wz / angle
        c, s = np.cos(angle), np.sin(angle)
        # a = e cos + (k x e) sin + k (k·e)(1 - cos), e = e_z
        axes[i, 0] = ky * s + kx * kz * (1 - c)
        axes[i, 1] = -kx * s + ky * kz * (1 - c)
        axes[i, 2] = c + kz * kz * (1 - c)
    return axes


@njit(cache=True)
def node_kinematics(positions: np.ndarray, velocities: np.ndarray,
                    half_lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node positions and velocities (12 x 3 each) of the six rods; node 2i = c - h a, 2i+1 = c + h a."""
    axes = rod_axes(positions)
    p = np.empty((12, 3))
    v = np.empty((12, 3))
    for i in range(6):
        h = half_lengths[i]
        w = velocities[6 * i:6 * i + 3]
        for s_idx in range(2):
            sign = -1.0 if s_idx == 0 else 1.0
            n = 2 * i + s_idx
            rx, ry, rz = sign * h * axes[i, 0], sign * h * axes[i, 1], sign * h * axes[i, 2]
            p[n, 0] = positions[6 * i + 3] + rx
            p[n, 1] = positions[6 * i + 4] + ry
            p[n, 2] = positions[6 * i + 5] + rz
            v[n, 0] = velocities[6 * i + 3] + w[1] * rz - w[2] * ry
            v[n, 1] = velocities[6 * i + 4] + w[2] * rx - w[0] * rz
            v[n, 2] = velocities[6 * i + 5] + w[0] * ry - w[1] * rx
    return p, v, axes


@njit(cache=True)
def add_node_forces(axes: np.ndarray, half_lengths: np.ndarray, node_forces: np.ndarray,
                    forces_out: np.ndarray) -> None:
    """Add node forces (12 x 3) [N] to the FreeJoint generalised forces (36,): per rod the world
    torque (h a) × (f1 - f0) about the centre and the force f0 + f1 (the layout of cable_wrenches)."""
    for i in range(6):
        h = half_lengths[i]
        ax, ay, az = axes[i, 0], axes[i, 1], axes[i, 2]
        f0 = node_forces[2 * i]
        f1 = node_forces[2 * i + 1]
        dfx, dfy, dfz = f1[0] - f0[0], f1[1] - f0[1], f1[2] - f0[2]
        forces_out[6 * i] += h * (ay * dfz - az * dfy)
        forces_out[6 * i + 1] += h * (az * dfx - ax * dfz)
        forces_out[6 * i + 2] += h * (ax * dfy - ay * dfx)
        forces_out[6 * i + 3] += f0[0] + f1[0]
        forces_out[6 * i + 4] += f0[1] + f1[1]
        forces_out[6 * i + 5] += f0[2] + f1[2]


@njit(cache=True)
def cable_wrenches(positions: np.ndarray, velocities: np.ndarray, half_lengths: np.ndarray,
                   end_a: np.ndarray, end_b: np.ndarray, rest_lengths: np.ndarray,
                   stiffness: float, damping: float, quadratic: float, hysteresis: float, spin_damping: float,
                   forces_out: np.ndarray, tension_out: np.ndarray, length_out: np.ndarray) -> float:
    """Generalised forces (36,) of all cables on the six FreeJoints, written into ``forces_out``.

    Also writes cable tensions F (24,) [N] and lengths L (24,) [m]. Returns the largest squared
    node speed [m²/s²] (NaN if the state is not finite), the per-step divergence guard.
    """
    p, v, axes = node_kinematics(positions, velocities, half_lengths)
    fastest = 0.0
    for n in range(12):
        s2 = v[n, 0] * v[n, 0] + v[n, 1] * v[n, 1] + v[n, 2] * v[n, 2]
        if not s2 <= fastest:       # also catches NaN
            fastest = s2
    node_f = np.zeros((12, 3))
    for j in range(end_a.shape[0]):
        a, b = end_a[j], end_b[j]
        dx, dy, dz = p[b, 0] - p[a, 0], p[b, 1] - p[a, 1], p[b, 2] - p[a, 2]
        length = np.sqrt(dx * dx + dy * dy + dz * dz)
        length_out[j] = length
        stretch = length - rest_lengths[j]
        if stretch <= 0.0 or length < 1e-12:
            tension_out[j] = 0.0
            continue
        ux, uy, uz = dx / length, dy / length, dz / length
        rate = (v[b, 0] - v[a, 0]) * ux + (v[b, 1] - v[a, 1]) * uy + (v[b, 2] - v[a, 2]) * uz
        f = cable_tension(stretch, rate, stiffness, damping, quadratic, hysteresis)
        tension_out[j] = f
        node_f[a, 0] += f * ux
        node_f[a, 1] += f * uy
        node_f[a, 2] += f * uz
        node_f[b, 0] -= f * ux
        node_f[b, 1] -= f * uy
        node_f[b, 2] -= f * uz
    forces_out[:] = 0.0
    add_node_forces(axes, half_lengths, node_f, forces_out)
    for i in range(6):            # the axial spin damper: τ = -c_spin (ω·a) a
        ax, ay, az = axes[i, 0], axes[i, 1], axes[i, 2]
        w = velocities[6 * i:6 * i + 3]
        spin = spin_damping * (w[0] * ax + w[1] * ay + w[2] * az)
        forces_out[6 * i] -= spin * ax
        forces_out[6 * i + 1] -= spin * ay
        forces_out[6 * i + 2] -= spin * az
    return fastest


def cable_energy(lengths: np.ndarray, rest_lengths: np.ndarray, stiffness: float, quadratic: float = 0.0) -> float:
    """Elastic energy Σ_j k (s_j²/2 + β s_j³/3) [J], s_j = max(0, L_j - L0_j), of the cables
    (the potential of F_k = k s (1 + β s); hysteresis has none: it dissipates)."""
    stretch = np.maximum(0.0, np.asarray(lengths) - np.asarray(rest_lengths))
    return float(stiffness * np.sum(stretch**2 / 2 + quadratic * stretch**3 / 3))
