"""Geometry of the T6 (SUPERball) tensegrity: nodes, rods, cables, faces and rod mass properties.

With h = rod_length / 2 and s = rod_space the 12 nodes (rod endpoints) are::

    n0=(-s,-h,0)  n1=(-s,h,0)   n2=(s,-h,0)   n3=(s,h,0)     rods along y
    n4=(0,-s,-h)  n5=(0,-s,h)   n6=(0,s,-h)   n7=(0,s,h)     rods along z
    n8=(-h,0,s)   n9=(h,0,s)    n10=(-h,0,-s) n11=(h,0,-s)   rods along x

Rod i joins nodes 2i and 2i+1. Each of the 24 cables joins nodes of different rods; every node has
four. Source: NTRT's ``src/examples/SUPERball/T6Model.cpp`` (NASA-Tensegrity-Robotics-Toolkit/NTRTsim).
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from physics.errors import PhysicsError

__all__ = [
    "N_RODS", "N_NODES", "N_CABLES", "ROD_NODES", "CABLE_NODES", "CABLE_NAMES",
    "node_positions", "closed_faces", "RodMassProperties", "rod_mass_properties",
    "rotation_onto_face", "rotation_between", "rod_poses_from_nodes",
]

N_RODS = 6
N_NODES = 12
N_CABLES = 24

#: Rod i joins nodes ROD_NODES[i] (shape 6 x 2).
ROD_NODES = np.arange(12).reshape(6, 2)

#: Cable j joins nodes CABLE_NODES[j] = (end_a, end_b) (shape 24 x 2).
CABLE_NODES = np.array(
    [(0, 4), (0, 5), (0, 8), (0, 10), (1, 6), (1, 7), (1, 8), (1, 10),
     (2, 4), (2, 5), (2, 9), (2, 11), (3, 6), (3, 7), (3, 9), (3, 11),
     (4, 10), (4, 11), (5, 8), (5, 9), (6, 10), (6, 11), (7, 8), (7, 9)],
    dtype=np.int64,
)
CABLE_NAMES = tuple(f"c{a:02d}_{b:02d}" for a, b in CABLE_NODES)


def node_positions(rod_length: float, rod_space: float) -> np.ndarray:
    """Node positions of the upright T6 centred at the origin, shape ``12 x 3`` [m]."""
    h, s = 0.5 * rod_length, rod_space
    return np.array([
        (-s, -h, 0), (-s, h, 0), (s, -h, 0), (s, h, 0),
        (0, -s, -h), (0, -s, h), (0, s, -h), (0, s, h),
        (-h, 0, s), (h, 0, s), (-h, 0, -s), (h, 0, -s),
    ], dtype=float)


def closed_faces() -> list[tuple[int, int, int]]:
    """The 8 triangles whose three edges are all cables (sorted node triples)."""
    edges = {tuple(sorted(e)) for e in CABLE_NODES.tolist()}
    nbrs = {i: {b for a, b in edges if a == i} | {a for a, b in edges if b == i} for i in range(N_NODES)}
    faces = []
    for a, b, c in combinations(range(N_NODES), 3):
        if b in nbrs[a] and c in nbrs[a] and c in nbrs[b]:
            faces.append((a, b, c))
    return faces


def rotation_onto_face(nodes: np.ndarray, face: tuple[int, int, int]) -> np.ndarray:
    """Rotation matrix (3 x 3) that turns the outward normal of ``face`` to −z (face down)."""
    tri = nodes[list(face)]
    normal = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    normal /= np.linalg.norm(normal)
    if normal @ tri.mean(axis=0) < 0:          # make it point away from the centre
        normal = -normal
    return rotation_between(normal, np.array([0.0, 0.0, -1.0]))


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation matrix (3 x 3) that turns the unit vector ``a`` (3,) onto the unit vector ``b`` (3,)
    about their common normal (Rodrigues' formula); a half turn about x when they are opposite."""
    axis = np.cross(a, b)
    sin, cos = np.linalg.norm(axis), float(a @ b)
    if sin < 1e-12:
        return np.eye(3) if cos > 0 else np.diag([1.0, -1.0, -1.0])
    k = axis / sin
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + sin * K + (1 - cos) * K @ K


@dataclass(frozen=True)
class RodMassProperties:
    """Mass [kg] and principal moments of inertia [kg m^2] of one rod about its centre.

    ``axial`` is about the rod axis, ``transverse`` about any perpendicular axis.
    """

    mass: float
    axial: float
    transverse: float
    end_length: float


def rod_mass_properties(density: float, radius: float, density_mp: float, radius_mp: float,
                        rod_length: float, rod_length_mp: float) -> RodMassProperties:
    """Three coaxial solid cylinders: end (length l_e), middle (rod_length_mp), end.

    l_e = (rod_length − rod_length_mp)/2, m_e = ρ π r² l_e, m_mp = ρ_mp π r_mp² l_mp;
    I_axial = 2·m_e r²/2 + m_mp r_mp²/2;
    I_trans = 2·[m_e (3r² + l_e²)/12 + m_e d²] + m_mp (3 r_mp² + l_mp²)/12,  d = (l_mp + l_e)/2.
    """
    end_length = 0.5 * (rod_length - rod_length_mp)
    if end_length <= 0:
        from physics.errors import ParameterError
        raise ParameterError(
            f"rod_length_mp ({rod_length_mp!r} m) must be shorter than rod_length ({rod_length!r} m): "
            "the end segments would have non-positive length."
        )
    m_e = density * np.pi * radius**2 * end_length
    m_mp = density_mp * np.pi * radius_mp**2 * rod_length_mp
    d = 0.5 * (rod_length_mp + end_length)
    axial = m_e * radius**2 + 0.5 * m_mp * radius_mp**2
    transverse = (2 * (m_e * (3 * radius**2 + end_length**2) / 12 + m_e * d**2)
                  + m_mp * (3 * radius_mp**2 + rod_length_mp**2) / 12)
    return RodMassProperties(float(2 * m_e + m_mp), float(axial), float(transverse), float(end_length))


def _rotvec_z_to(axis: np.ndarray) -> np.ndarray:
    """Rotation vectors (n x 3) of the smallest rotations taking e_z to each unit ``axis`` (n x 3)."""
    axis = np.atleast_2d(axis)
    ez = np.array([0.0, 0.0, 1.0])
    cross = np.cross(ez, axis)
    sin = np.linalg.norm(cross, axis=1)
    cos = axis @ ez
    angle = np.arctan2(sin, cos)
    out = np.zeros_like(axis)
    ok = sin > 1e-12
    out[ok] = cross[ok] / sin[ok, None] * angle[ok, None]
    flip = (~ok) & (cos < 0)
    out[flip] = np.array([np.pi, 0.0, 0.0])
    return out


def rod_poses_from_nodes(nodes: np.ndarray,
                         node_velocities: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """FreeJoint positions and velocities (36,) from node positions (12 x 3) and velocities.

    Centre c = (n0 + n1)/2, axis a = (n1 - n0)/|n1 - n0|, v = (v0 + v1)/2,
    ω = a × (v1 - v0) / |n1 - n0| (the spin about the axis is unobservable from nodes and set to
    0; with anchors on the axis and axisymmetric rods it does not act on the cables).
    """
    n0, n1 = nodes[0::2], nodes[1::2]
    d = n1 - n0
    length = np.linalg.norm(d, axis=1)
    if np.any(~np.isfinite(length)) or np.any(length < 1e-9):
        raise PhysicsError("Cannot place rods: some node pairs coincide or are not finite.")
    axis = d / length[:, None]
    q = np.concatenate([_rotvec_z_to(axis), 0.5 * (n0 + n1)], axis=1).reshape(-1)
    if node_velocities is None:
        return q, np.zeros(36)
    v0, v1 = node_velocities[0::2], node_velocities[1::2]
    omega = np.cross(axis, v1 - v0) / length[:, None]
    dq = np.concatenate([omega, 0.5 * (v0 + v1)], axis=1).reshape(-1)
    return q, dq
