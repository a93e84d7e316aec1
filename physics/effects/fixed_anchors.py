"""Cable anchors fixed to the rods: each cable end sits on the end cap's rim, ``fixed_anchor_offset`` [m]
off the axis, at a point of the rod's body frame (as on SUPERball, and in engines that attach
cables to rigid bodies), so a rod turns about its own axis under the cables' torque.

:class:`~physics.effects.anchors.CableAnchors` re-aims every anchor toward the cable's other end
at each step, so the cables never twist a rod; here the anchors turn with the rod. For cable j
between rods r_a, r_b (centres c, rotations R, body-frame anchors ℓ_a, ℓ_b set at build toward the
other end, as CableAnchors places them there):

    p_a = c_a + R_a ℓ_a,   p_b = c_b + R_b ℓ_b,   ê = unit(p_b - p_a)
    T_j' = max(0, T_j + k ((|p_b - p_a| - |n_b - n_a|) - δ_j) + c (dL_p/dt - dL_n/dt))

with T_j the node cable's tension, δ_j = L_anchor,build - L_node,build (assembled anchor to anchor
with the same pretension), dL/dt the rates of the anchor-to-anchor and node-to-node lengths. Each
step the node cable's wrench is removed and T_j' ê applied at the anchors, with its full torque
about each rod's centre (the axial part included). The cables themselves resist and damp the
spin, so the model's axial spin damper is switched off (``ModelSetup.spin_damping = 0``).

The spin about a rod's axis is not in the observed nodes. When rods are placed from nodes (build,
or an observed sample), each rod is turned about its axis by the angle φ that best aims its
anchors at their cables' other ends (least squares on the circle, per rod over its 8 anchors
with body-frame angles α_k and aimed angles β_k: φ = atan2(Σ sin(β_k − α_k), Σ cos(β_k − α_k))),
the pose in which the cables exert no axial torque on a resting rod.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit
from scipy.spatial.transform import Rotation

from physics.effects.anchors import anchor_points, rest_shift
from physics.effects.base import Effect, ModelSetup
from physics.geometry import CABLE_NODES, node_positions, rod_poses_from_nodes
from physics.parameters import Parameter

__all__ = ["FixedCableAnchors", "body_anchors", "fixed_anchor_wrenches", "orient_rods"]

_A = np.ascontiguousarray(CABLE_NODES[:, 0])
_B = np.ascontiguousarray(CABLE_NODES[:, 1])


@njit(cache=True)
def _rotation(w: np.ndarray) -> np.ndarray:
    """Rotation matrix (3 x 3) of the rotation vector w (3,) (Rodrigues)."""
    angle = np.sqrt((w * w).sum())
    out = np.eye(3)
    if angle < 1e-12:
        out[0, 1], out[0, 2], out[1, 2] = -w[2], w[1], -w[0]
        out[1, 0], out[2, 0], out[2, 1] = w[2], -w[1], w[0]
        return out
    k = w / angle
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return out + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


@njit(cache=True)
def _add_wrench(out: np.ndarray, rod: int, arm: np.ndarray, fx: float, fy: float, fz: float) -> None:
    """Add a force (fx, fy, fz) [N] applied at ``arm`` (3,) from the rod's centre to its generalised forces."""
    out[6 * rod] += arm[1] * fz - arm[2] * fy
    out[6 * rod + 1] += arm[2] * fx - arm[0] * fz
    out[6 * rod + 2] += arm[0] * fy - arm[1] * fx
    out[6 * rod + 3] += fx
    out[6 * rod + 4] += fy
    out[6 * rod + 5] += fz


@njit(cache=True)
def _ends(q: np.ndarray, dq: np.ndarray, half: np.ndarray, local: np.ndarray, rot: np.ndarray, j: int,
          arms: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> None:
    """Arms from the rod centres, positions and velocities (each [end a/b][node, anchor] x 3) of cable j's ends."""
    for s in range(2):
        node = _A[j] if s == 0 else _B[j]
        r = node // 2
        sign = 1.0 if node % 2 == 1 else -1.0
        for k in range(3):
            arms[s, 0, k] = sign * half[r] * rot[r, k, 2]
            arms[s, 1, k] = (rot[r, k, 0] * local[j, s, 0] + rot[r, k, 1] * local[j, s, 1]
                             + rot[r, k, 2] * local[j, s, 2])
        wx, wy, wz = dq[6 * r], dq[6 * r + 1], dq[6 * r + 2]
        for m in range(2):
            ax, ay, az = arms[s, m, 0], arms[s, m, 1], arms[s, m, 2]
            vel[s, m, 0] = dq[6 * r + 3] + wy * az - wz * ay
            vel[s, m, 1] = dq[6 * r + 4] + wz * ax - wx * az
            vel[s, m, 2] = dq[6 * r + 5] + wx * ay - wy * ax
            for k in range(3):
                pos[s, m, k] = q[6 * r + 3 + k] + arms[s, m, k]


@njit(cache=True)
def _along(x: np.ndarray, m: int) -> tuple[float, float, float, float]:
    """Unit vector (3 floats) from end a to end b of points ``x[:, m]`` and their distance."""
    dx, dy, dz = x[1, m, 0] - x[0, m, 0], x[1, m, 1] - x[0, m, 1], x[1, m, 2] - x[0, m, 2]
    n = np.sqrt(dx * dx + dy * dy + dz * dz)
    return dx / n, dy / n, dz / n, n


@njit(cache=True)
def _rate(vel: np.ndarray, m: int, ux: float, uy: float, uz: float) -> float:
    """Rate [m/s] at which points ``m`` of the two ends move apart along (ux, uy, uz)."""
    return ((vel[1, m, 0] - vel[0, m, 0]) * ux + (vel[1, m, 1] - vel[0, m, 1]) * uy
            + (vel[1, m, 2] - vel[0, m, 2]) * uz)


@njit(cache=True)
def fixed_anchor_wrenches(q: np.ndarray, dq: np.ndarray, half: np.ndarray, local: np.ndarray, tension: np.ndarray,
                          stiffness: float, damping: float, delta: np.ndarray, out: np.ndarray) -> None:
    """Add to the generalised forces ``out`` (36,) the anchored cables' wrenches minus the node
    cables' (module docstring). q, dq: FreeJoint positions and velocities (36,); half: half rod
    lengths (6,); local: body-frame anchors (24 x 2 x 3) [m]; tension: node-cable tensions (24,) [N]."""
    rot = np.empty((6, 3, 3))
    for r in range(6):
        rot[r] = _rotation(q[6 * r:6 * r + 3])
    arms, pos, vel = np.empty((2, 2, 3)), np.empty((2, 2, 3)), np.empty((2, 2, 3))
    for j in range(_A.shape[0]):
        _ends(q, dq, half, local, rot, j, arms, pos, vel)
        ux, uy, uz, length = _along(pos, 0)
        ex, ey, ez, anchored = _along(pos, 1)
        t_node = tension[j]
        t_anchor = 0.0
        if t_node > 0.0:
            rate_n = _rate(vel, 0, ux, uy, uz)
            rate_a = _rate(vel, 1, ex, ey, ez)
            t_anchor = max(0.0, t_node + stiffness * ((anchored - length) - delta[j]) + damping * (rate_a - rate_n))
        ra, rb = _A[j] // 2, _B[j] // 2
        _add_wrench(out, ra, arms[0, 0], -t_node * ux, -t_node * uy, -t_node * uz)
        _add_wrench(out, rb, arms[1, 0], t_node * ux, t_node * uy, t_node * uz)
        _add_wrench(out, ra, arms[0, 1], t_anchor * ex, t_anchor * ey, t_anchor * ez)
        _add_wrench(out, rb, arms[1, 1], -t_anchor * ex, -t_anchor * ey, -t_anchor * ez)


def body_anchors(rod_length: float, rod_space: float, offset: float) -> np.ndarray:
    """Body-frame anchors (24 x 2 x 3) [m]: the anchors of CableAnchors at the build layout, in the
    frame rod_poses_from_nodes gives each rod there (origin at its centre, z along its axis)."""
    build = node_positions(rod_length, rod_space)
    world = anchor_points(build, offset)
    q, _ = rod_poses_from_nodes(build)
    rot = Rotation.from_rotvec(q.reshape(6, 6)[:, :3]).as_matrix()
    centre = q.reshape(6, 6)[:, 3:]
    out = np.empty_like(world)
    for s, ends in enumerate((_A, _B)):
        rods = ends // 2
        out[:, s] = np.einsum("jba,jb->ja", rot[rods], world[:, s] - centre[rods])
    return out


def orient_rods(q: np.ndarray, local: np.ndarray, offset: float, half: float) -> np.ndarray:
    """FreeJoint positions ``q`` (36,) with each rod (half length ``half`` [m]) turned about its own
    axis so that its anchors ``local`` (24 x 2 x 3) best aim at their cables' other ends (module docstring)."""
    q = np.array(q, dtype=float).reshape(6, 6)
    rot = Rotation.from_rotvec(q[:, :3]).as_matrix()
    tips = half * np.stack([-rot[:, :, 2], rot[:, :, 2]], axis=1)
    aimed = anchor_points((q[:, None, 3:] + tips).reshape(12, 3), offset)
    sums = np.zeros((6, 2))
    for s, ends in enumerate((_A, _B)):
        rods = ends // 2
        target = np.einsum("jba,jb->ja", rot[rods], aimed[:, s] - q[rods, 3:])
        diff = np.arctan2(target[:, 1], target[:, 0]) - np.arctan2(local[:, s, 1], local[:, s, 0])
        np.add.at(sums, rods, np.stack([np.sin(diff), np.cos(diff)], axis=1))
    phi = np.arctan2(sums[:, 0], sums[:, 1])
    turned = Rotation.from_matrix(rot) * Rotation.from_rotvec(np.outer(phi, [0.0, 0.0, 1.0]))
    q[:, :3] = turned.as_rotvec()
    return q.reshape(-1)


class FixedCableAnchors(Effect):
    """Cables anchored ``anchor_offset`` [m] off the rod axis at points fixed to the rods, which turn
    about their axes under the cables' torque (module docstring)."""

    name = "fixed_anchors"
    description = "cable ends fixed on the end caps' rims: the rods turn about their axes under the cables"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("fixed_anchor_offset", "m", 0.0, 0.0, 0.1,
                          "distance of a cable's anchor from its node, fixed to the rod", strict=False),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        offset = float(values["fixed_anchor_offset"])
        if offset <= 0.0:
            return
        local = body_anchors(params["rod_length"], params["rod_space"], offset)
        delta = rest_shift(params["rod_length"], params["rod_space"], offset)
        half = np.full(6, 0.5 * float(params["rod_length"]))
        stiffness, damping, tension = float(params["stiffnessActive"]), float(params["damping"]), setup.tension

        def term(q: np.ndarray, dq: np.ndarray, out: np.ndarray) -> None:
            fixed_anchor_wrenches(q, dq, half, local, tension, stiffness, damping, delta, out)

        setup.wrench_terms.append(term)
        setup.spin_damping = 0.0
        setup.orient = lambda q: orient_rods(q, local, offset, 0.5 * float(params["rod_length"]))
