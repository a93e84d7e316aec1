"""Cable anchors off the rod axis: each cable end sits ``anchor_offset`` [m] from its node, on the
end cap's rim, toward the cable's other end (as on SUPERball's end caps and in NTRT-like engines).

The T6's cable kernel (physics.cables) pulls on the nodes, on the rod axis. For cable j between
nodes a and b (rod axes â, b̂) the anchors are

    e_a = unit((n_b - n_a) - ((n_b - n_a)·â) â),   p_a = n_a + ρ e_a      (and p_b alike, ρ = anchor_offset)

and the cable pulls along p_b - p_a. Its rest length is the model's plus δ_j = L_anchor,build -
L_node,build (the cable was assembled anchor to anchor with the same pretension), so its tension is

    T_j' = max(0, T_j + k ((|p_b - p_a| - |n_b - n_a|) - δ_j))

with T_j the node cable's tension (damping included). Each step this effect removes the node
cable's force and applies T_j' at the anchors, as node forces with the same net force and the
same torque perpendicular to the rod (a torque about a rod's own axis cannot be carried by its
two nodes; the model's axial spin damper stands for it). ρ = 0 is the T6 without the effect. A
cable still never pushes: T_j' >= 0 along the anchor-to-anchor line.

The node cables' tensions are those the model writes into ``ModelSetup.tension`` each step
before the force terms run, so the correction holds from the first step on, whichever actuator
drives the cables.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit

from physics.effects.base import Effect, ModelSetup
from physics.geometry import CABLE_NODES, node_positions
from physics.parameters import Parameter

__all__ = ["CableAnchors", "anchor_points", "anchor_forces", "rest_shift"]

_A = np.ascontiguousarray(CABLE_NODES[:, 0])
_B = np.ascontiguousarray(CABLE_NODES[:, 1])


@njit(cache=True)
def _anchor_xyz(nodes: np.ndarray, me: int, other: int, offset: float) -> tuple[float, float, float]:
    """Anchor (x, y, z) of the cable end at node ``me`` toward node ``other``: ``offset`` off the axis."""
    mate = me ^ 1
    ax, ay, az = nodes[mate, 0] - nodes[me, 0], nodes[mate, 1] - nodes[me, 1], nodes[mate, 2] - nodes[me, 2]
    n = np.sqrt(ax * ax + ay * ay + az * az)
    ax, ay, az = ax / n, ay / n, az / n
    dx, dy, dz = nodes[other, 0] - nodes[me, 0], nodes[other, 1] - nodes[me, 1], nodes[other, 2] - nodes[me, 2]
    dot = dx * ax + dy * ay + dz * az
    px, py, pz = dx - dot * ax, dy - dot * ay, dz - dot * az
    norm = np.sqrt(px * px + py * py + pz * pz)
    if norm < 1e-12:
        return nodes[me, 0], nodes[me, 1], nodes[me, 2]
    s = offset / norm
    return nodes[me, 0] + s * px, nodes[me, 1] + s * py, nodes[me, 2] + s * pz


@njit(cache=True)
def _anchor(nodes: np.ndarray, me: int, other: int, offset: float) -> np.ndarray:
    """Anchor (3,) of the cable end at node ``me`` toward node ``other``: ``offset`` off the axis."""
    x, y, z = _anchor_xyz(nodes, me, other, offset)
    return np.array([x, y, z])


def rest_shift(rod_length: float, rod_space: float, offset: float) -> np.ndarray:
    """δ (24,) [m]: anchor-to-anchor minus node-to-node build length of each cable, the shift of its
    rest length that keeps the pretension of a cable assembled anchor to anchor."""
    build = node_positions(rod_length, rod_space)
    anchors = anchor_points(build, offset)
    return np.linalg.norm(anchors[:, 1] - anchors[:, 0], axis=1) - np.linalg.norm(build[_B] - build[_A], axis=1)


def anchor_points(nodes: np.ndarray, offset: float) -> np.ndarray:
    """Anchors (24 x 2 x 3) [m] of the cables at node positions (12 x 3) (module docstring)."""
    out = np.empty((len(_A), 2, 3))
    for j in range(len(_A)):
        out[j, 0] = _anchor(nodes, _A[j], _B[j], offset)
        out[j, 1] = _anchor(nodes, _B[j], _A[j], offset)
    return out


@njit(cache=True)
def _at_anchor(nodes: np.ndarray, node: int, p: tuple[float, float, float], f: tuple[float, float, float],
               out: np.ndarray) -> None:
    """Add the force f acting at point p on the rod of ``node`` to its two nodes: same net force,
    same torque perpendicular to the rod about its centre (f1 − f0 = g with h a × g = that torque)."""
    lo = node - node % 2
    sx, sy, sz = nodes[lo + 1, 0] - nodes[lo, 0], nodes[lo + 1, 1] - nodes[lo, 1], nodes[lo + 1, 2] - nodes[lo, 2]
    span = np.sqrt(sx * sx + sy * sy + sz * sz)
    h = 0.5 * span
    ax, ay, az = sx / span, sy / span, sz / span
    rx = p[0] - 0.5 * (nodes[lo, 0] + nodes[lo + 1, 0])
    ry = p[1] - 0.5 * (nodes[lo, 1] + nodes[lo + 1, 1])
    rz = p[2] - 0.5 * (nodes[lo, 2] + nodes[lo + 1, 2])
    tx, ty, tz = ry * f[2] - rz * f[1], rz * f[0] - rx * f[2], rx * f[1] - ry * f[0]
    dot = tx * ax + ty * ay + tz * az
    tx, ty, tz = tx - dot * ax, ty - dot * ay, tz - dot * az
    g = ((ty * az - tz * ay) / h, (tz * ax - tx * az) / h, (tx * ay - ty * ax) / h)
    for k in range(3):
        out[lo, k] += 0.5 * (f[k] - g[k])
        out[lo + 1, k] += 0.5 * (f[k] + g[k])


@njit(cache=True)
def anchor_forces(nodes: np.ndarray, tension: np.ndarray, offset: float, stiffness: float,
                  delta: np.ndarray, out: np.ndarray) -> None:
    """Add to ``out`` (12 x 3) [N] the anchor cables' node forces minus the node cables' (module
    docstring), from node positions (12 x 3) and node-cable tensions (24,) [N]."""
    for j in range(_A.shape[0]):
        a, b = _A[j], _B[j]
        dx, dy, dz = nodes[b, 0] - nodes[a, 0], nodes[b, 1] - nodes[a, 1], nodes[b, 2] - nodes[a, 2]
        length = np.sqrt(dx * dx + dy * dy + dz * dz)
        pa, pb = _anchor_xyz(nodes, a, b, offset), _anchor_xyz(nodes, b, a, offset)
        ex, ey, ez = pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]
        anchored = np.sqrt(ex * ex + ey * ey + ez * ez)
        t_node = tension[j]
        t_anchor = 0.0
        if t_node > 0.0:
            t_anchor = max(0.0, t_node + stiffness * ((anchored - length) - delta[j]))
        out[a, 0] -= t_node * dx / length
        out[a, 1] -= t_node * dy / length
        out[a, 2] -= t_node * dz / length
        out[b, 0] += t_node * dx / length
        out[b, 1] += t_node * dy / length
        out[b, 2] += t_node * dz / length
        s = t_anchor / anchored
        _at_anchor(nodes, a, pa, (s * ex, s * ey, s * ez), out)
        _at_anchor(nodes, b, pb, (-s * ex, -s * ey, -s * ez), out)


class CableAnchors(Effect):
    """Cables anchored ``anchor_offset`` [m] off the rod axis, on the end caps' rims (module docstring)."""

    name = "cable_anchors"
    description = "cable ends anchored on the end caps' rims, off the rod axis"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("anchor_offset", "m", 0.0, 0.0, 0.1, "distance of a cable's anchor from its node",
                          strict=False),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        offset = float(values["anchor_offset"])
        if offset <= 0.0:
            return
        delta = rest_shift(params["rod_length"], params["rod_space"], offset)
        stiffness, tension = float(params["stiffnessActive"]), setup.tension

        def term(nodes: np.ndarray, velocities: np.ndarray, out: np.ndarray) -> None:
            anchor_forces(nodes, tension, offset, stiffness, delta, out)

        setup.force_terms.append(term)
