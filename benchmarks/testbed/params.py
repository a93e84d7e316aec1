"""The testbed robot's 15 parameters (SI) and its geometry, written from the SUPERball facts.

Names and nominal values are SUPERball's (NTRT's T6Model.cpp, docs/parameters.md), so that a data set
can state the θ that made it in the names an identifier uses. The box is ±10 % around nominal.
The testbed's actuator is NTRT's basic one (rest length toward target at a limited speed), so the
three motor parameters (motor_radius, motor_friction, motor_inertia) are inert here, as they were
in the paper's own NTRT simulation; the other 12 act.
"""
from __future__ import annotations

import itertools

import numpy as np

__all__ = ["NOMINAL", "NAMES", "ACTIVE", "ROD_ENDS", "CABLE_ENDS", "cable_names", "node_layout",
           "closed_faces", "draw_theta"]

NOMINAL: dict[str, float] = {
    "density": 311.0, "radius": 0.06, "density_mp": 104.0, "radius_mp": 0.035, "rod_length": 1.74,
    "rod_space": 0.45, "rod_length_mp": 1.0, "stiffnessActive": 800.0, "damping": 200.0,
    "pretension": 150.0, "maxTens": 300.0, "targetVelocity": 1.5, "motor_radius": 0.009,
    "motor_friction": 8.48e-5, "motor_inertia": 1.0996e-3,
}
NAMES: tuple[str, ...] = tuple(NOMINAL)
INERT = ("motor_radius", "motor_friction", "motor_inertia")
ACTIVE: tuple[str, ...] = tuple(n for n in NAMES if n not in INERT)

#: rod i joins nodes 2i and 2i+1
ROD_ENDS = np.arange(12).reshape(6, 2)
#: the 24 cables as (node a, node b), in the order of the data format
CABLE_ENDS = np.array([
    (0, 4), (0, 5), (0, 8), (0, 10), (1, 6), (1, 7), (1, 8), (1, 10), (2, 4), (2, 5), (2, 9), (2, 11),
    (3, 6), (3, 7), (3, 9), (3, 11), (4, 10), (4, 11), (5, 8), (5, 9), (6, 10), (6, 11), (7, 8), (7, 9),
])


def cable_names() -> list[str]:
    """Cable names ``cAA_BB`` of the data format, in order (24,)."""
    return [f"c{a:02d}_{b:02d}" for a, b in CABLE_ENDS]


def node_layout(rod_length: float, rod_space: float) -> np.ndarray:
    """Rod endpoints (12 x 3) [m] of the T6 before it is placed: three pairs of parallel rods along
    y, z and x, each pair ``rod_space`` from the centre plane, rods ``rod_length`` long."""
    h, s = 0.5 * rod_length, rod_space
    return np.array([
        (-s, -h, 0), (-s, h, 0), (s, -h, 0), (s, h, 0),
        (0, -s, -h), (0, -s, h), (0, s, -h), (0, s, h),
        (-h, 0, s), (h, 0, s), (-h, 0, -s), (h, 0, -s),
    ], float)


def closed_faces() -> list[tuple[int, int, int]]:
    """Triangles of three nodes joined pairwise by cables (the faces the robot can rest on)."""
    joined = {tuple(sorted(e)) for e in CABLE_ENDS.tolist()}
    return [t for t in itertools.combinations(range(12), 3)
            if all(tuple(sorted(p)) in joined for p in itertools.combinations(t, 2))]


def draw_theta(rng: np.random.Generator, *, spread: float = 0.1) -> dict[str, float]:
    """θ* with each active parameter drawn uniformly within ±``spread`` of nominal (inert ones nominal)."""
    theta = dict(NOMINAL)
    for name in ACTIVE:
        theta[name] = NOMINAL[name] * (1.0 + rng.uniform(-spread, spread))
    return theta
