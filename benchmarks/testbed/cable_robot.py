"""The testbed SUPERball's hardware, whatever engine moves its rods: cables, actuators, payload, effects.

The robot is the same in every engine; what an engine brings is the rigid bodies, their contact
with the ground and the integration. :class:`CableRobot` holds the robot's side (docs/testbed.md):

- each rod has the mass and inertia of three coaxial cylinders (ends: ``density``, ``radius``;
  middle: ``density_mp``, ``radius_mp``, ``rod_length_mp``), plus any payload;
- cable anchors sit on the rim of the end face, offset by ``radius`` from the node toward the
  other end of the cable (perpendicular to the rod), fixed to the rod;
- a cable pulls with F = k (L − L0) + c dL/dt only while L > L0 (it never pushes), with dL/dt a
  backward difference of L over one step and the damping term clipped to ±k (L − L0);
- the actuator moves each rest length L0 toward its target by at most targetVelocity·dt per step;
  a target that would make the tension exceed maxTens is lengthened to L − maxTens / k first.

Rest lengths at build are L0_build = L_build − pretension / k with L_build the anchor-to-anchor
distance. Encoders count spool travel since assembly; the data format (docs/data-format.md) says
a reading of L0_zero = |n_a − n_b| − pretension / k of the nominal robot (node to node, 0.878 m)
means "as assembled", so a reading is L0_zero + (L0 − L0_build(θ)) and a command c asks for the
true rest length c + (L0_build(θ) − L0_zero).

An engine subclasses it and gives :meth:`_make_world`, :meth:`_body_states`,
:meth:`_body_velocities`, :meth:`_advance` and the snapshot methods.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from testbed.effects import Effects
from testbed.params import CABLE_ENDS, NOMINAL, ROD_ENDS, closed_faces, node_layout

__all__ = ["CableRobot", "RodBody", "Snapshot", "TestbedDiverged", "build_pose", "rod_inertia", "encoder_zero",
           "rotation_between", "anchor_points", "build_lengths"]

_DT = 1e-3
_NEAR_GROUND = 0.01
_MAX_SPEED = 30.0


class TestbedDiverged(RuntimeError):
    """A node moved faster than 30 m/s or became NaN: the testbed simulation blew up."""


@dataclass(frozen=True)
class Snapshot:
    """The engine's saved state plus the cable side of the state (rest lengths, last lengths, pending commands)."""

    engine: object
    rest: np.ndarray
    last_length: np.ndarray
    pending: tuple
    time: float


@dataclass(frozen=True)
class RodBody:
    """What an engine builds for rod i: centre (3,) [m], rotation (3 x 3, column 2 along the rod),
    mass [kg], centre of mass ``com_along`` the axis from the centre [m], transverse and axial
    inertia about the centre of mass [kg m²]."""

    centre: np.ndarray
    rotation: np.ndarray
    mass: float
    com_along: float
    transverse: float
    axial: float


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation matrix (3 x 3) turning unit vector a onto unit vector b (Rodrigues)."""
    v, c = np.cross(a, b), float(a @ b)
    if np.linalg.norm(v) < 1e-12:
        if c > 0:
            return np.eye(3)
        p = np.eye(3)[np.argmin(np.abs(a))]
        axis = np.cross(a, p) / np.linalg.norm(np.cross(a, p))
        return 2 * np.outer(axis, axis) - np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)


def build_pose(theta: dict[str, float], effects: Effects, *, face: int = 0, drop: float = 0.02) -> np.ndarray:
    """Node positions (12 x 3) at build: closed face ``face`` toward the (possibly tilted) ground,
    every node at least ``radius + drop`` above it, centred over the world origin."""
    nodes = node_layout(theta["rod_length"], theta["rod_space"])
    tri = list(closed_faces()[face])
    outward = nodes[tri].mean(axis=0)
    normal = effects.ground_normal()
    nodes = nodes @ rotation_between(outward / np.linalg.norm(outward), -normal).T
    height = nodes @ normal
    return nodes + normal * (theta["radius"] + drop - height.min()) - np.r_[nodes[:, :2].mean(axis=0), 0.0]


def rod_inertia(theta: dict[str, float], effects: Effects, rod: int) -> tuple[float, float, float, float]:
    """(mass [kg], centre of mass along the axis from the rod's centre [m], transverse and axial
    inertia about the centre of mass [kg m²]) of three coaxial cylinders plus any payload."""
    l_mp = theta["rod_length_mp"]
    l_end = 0.5 * (theta["rod_length"] - l_mp)
    parts = [(theta["density"] * np.pi * theta["radius"] ** 2 * l_end, theta["radius"], l_end, z)
             for z in (-(l_mp + l_end) / 2, (l_mp + l_end) / 2)]
    parts.append((theta["density_mp"] * np.pi * theta["radius_mp"] ** 2 * l_mp, theta["radius_mp"], l_mp, 0.0))
    if effects.extra_mass > 0 and rod == effects.extra_mass_rod:
        parts.append((effects.extra_mass, 0.0, 0.0, effects.extra_mass_at))
    mass = sum(m for m, *_ in parts)
    zc = sum(m * z for m, _, _, z in parts) / mass
    transverse = sum(m * (3 * r ** 2 + l ** 2) / 12 + m * (z - zc) ** 2 for m, r, l, z in parts)
    axial = sum(0.5 * m * r ** 2 for m, r, _, _ in parts)
    return mass, zc, transverse, axial


def encoder_zero() -> np.ndarray:
    """The reading (24,) [m] the data format gives a rest length as assembled: node-to-node cable
    length of the nominal robot minus pretension / k (0.878 m for every cable)."""
    nodes = node_layout(NOMINAL["rod_length"], NOMINAL["rod_space"])
    length = np.linalg.norm(nodes[CABLE_ENDS[:, 1]] - nodes[CABLE_ENDS[:, 0]], axis=1)
    return length - NOMINAL["pretension"] / NOMINAL["stiffnessActive"]


def anchor_points(nodes: np.ndarray, radius: float) -> np.ndarray:
    """World anchors (24 x 2 x 3): each cable end on its node's rim, toward the other end."""
    out = np.empty((len(CABLE_ENDS), 2, 3))
    for j, ends in enumerate(CABLE_ENDS):
        for side, (me, other) in enumerate((ends, ends[::-1])):
            rod = ROD_ENDS[me // 2]
            axis = nodes[rod[1]] - nodes[rod[0]]
            axis /= np.linalg.norm(axis)
            d = nodes[other] - nodes[me]
            perp = d - (d @ axis) * axis
            out[j, side] = nodes[me] + radius * perp / np.linalg.norm(perp)
    return out


def build_lengths(theta: dict[str, float]) -> np.ndarray:
    """Anchor-to-anchor cable lengths (24,) [m] of the build pose at ``theta``."""
    anchors = anchor_points(node_layout(theta["rod_length"], theta["rod_space"]), theta["radius"])
    return np.linalg.norm(anchors[:, 1] - anchors[:, 0], axis=1)


class CableRobot:
    """The SUPERball at parameters ``theta`` (dict of the 15 names) with ``effects``, moved by an
    engine (a subclass). ``step(targets)`` advances 1 ms with 24 true target rest lengths [m]."""

    __test__ = False     # not a pytest class

    dt = _DT
    engine, engine_name = "", ""          # the subclass's: key in testbed.datasets.ENGINES, name in the files

    def __init__(self, theta: dict[str, float], effects: Effects = Effects(), *, face: int = 0) -> None:
        self.theta, self.effects = dict(theta), effects
        self.k, self.c = theta["stiffnessActive"], theta["damping"]
        nodes = build_pose(theta, effects, face=face)
        self._make_world(self._rod_bodies(nodes))
        self.rest = build_lengths(theta) - theta["pretension"] / self.k
        if np.any(self.rest <= 0):
            raise ValueError("pretension / stiffnessActive exceeds the cable length: rest lengths would be <= 0.")
        self.encoder_offset = self.rest - encoder_zero()
        self.last_length = self._cable_geometry(self._poses())[0]
        self.pending: deque = deque()
        self.time = 0.0

    def _rod_bodies(self, nodes: np.ndarray) -> list[RodBody]:
        """The six rods at the build pose; stores the anchors and centres of mass in body frames."""
        anchors = anchor_points(nodes, self.theta["radius"])
        self.com_offset, self.masses = np.zeros(6), np.zeros(6)
        self.anchor_local = np.empty((len(CABLE_ENDS), 2, 3))
        self.half = 0.5 * self.theta["rod_length"]
        rods = []
        for i, (a, b) in enumerate(ROD_ENDS):
            centre = 0.5 * (nodes[a] + nodes[b])
            axis = (nodes[b] - nodes[a]) / np.linalg.norm(nodes[b] - nodes[a])
            rot = rotation_between(np.array([0.0, 0.0, 1.0]), axis)
            mass, zc, transverse, axial = rod_inertia(self.theta, self.effects, i)
            rods.append(RodBody(centre, rot, mass, zc, transverse, axial))
            self.com_offset[i], self.masses[i] = zc, mass
            for j, ends in enumerate(CABLE_ENDS):
                for side in (0, 1):
                    if ends[side] // 2 == i:
                        self.anchor_local[j, side] = rot.T @ (anchors[j, side] - centre)
        return rods

    # ---------------------------------------------------------------- the engine's part
    def _make_world(self, rods: list[RodBody]) -> None:
        """Build the ground (normal ``effects.ground_normal()``) and the six rod bodies."""
        raise NotImplementedError

    def _body_states(self) -> tuple[np.ndarray, np.ndarray]:
        """(rotations 6 x 3 x 3, centres of mass 6 x 3) of the rods in the world frame."""
        raise NotImplementedError

    def _body_velocities(self) -> tuple[np.ndarray, np.ndarray]:
        """(linear velocities of the centres of mass 6 x 3 [m/s], angular velocities 6 x 3 [rad/s]), world frame."""
        raise NotImplementedError

    def _advance(self, net: np.ndarray, torque: np.ndarray, com: np.ndarray) -> None:
        """Apply forces ``net`` (6 x 3) [N] at the centres of mass ``com`` and torques (6 x 3) [N m], then step dt."""
        raise NotImplementedError

    def _save(self) -> object:
        raise NotImplementedError

    def _load(self, state: object) -> None:
        raise NotImplementedError

    def forget(self, snap: Snapshot) -> None:
        """Free what :meth:`snapshot` kept (nothing unless the engine holds it)."""

    def close(self) -> None:
        """Release the engine."""

    # ---------------------------------------------------------------- state
    def _poses(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rotations 6 x 3 x 3, rod centres 6 x 3, centres of mass 6 x 3) in the world frame."""
        rot, com = self._body_states()
        return rot, com - rot[:, :, 2] * self.com_offset[:, None], com

    def _cable_geometry(self, poses) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(lengths (24,), unit vectors a -> b (24 x 3), anchors (24 x 2 x 3)) of the cables."""
        rot, centre, _ = poses
        rods = CABLE_ENDS // 2
        anchors = np.einsum("jsab,jsb->jsa", rot[rods], self.anchor_local) + centre[rods]
        d = anchors[:, 1] - anchors[:, 0]
        length = np.linalg.norm(d, axis=1)
        return length, d / length[:, None], anchors

    def nodes(self, poses=None) -> np.ndarray:
        """Rod endpoints (12 x 3) [m] in the world frame: rod centre ∓ half a rod along its axis
        (``poses``: those of :meth:`_poses` if already read this step)."""
        rot, centre, _ = poses or self._poses()
        axis = rot[:, :, 2]
        return np.stack([centre - self.half * axis, centre + self.half * axis], axis=1).reshape(12, 3)

    def node_velocities(self, poses=None) -> np.ndarray:
        """Velocities (12 x 3) [m/s] of the rod endpoints."""
        poses = poses or self._poses()
        nodes = self.nodes(poses).reshape(6, 2, 3)
        v, w = self._body_velocities()
        return (v[:, None] + np.cross(w[:, None], nodes - poses[2][:, None])).reshape(12, 3)

    def tensions(self, length: np.ndarray | None = None) -> np.ndarray:
        """Spring tensions max(0, k (L − L0)) (24,) [N]."""
        length = self._cable_geometry(self._poses())[0] if length is None else length
        return np.maximum(0.0, self.k * (length - self.rest))

    def snapshot(self) -> Snapshot:
        """Everything needed to come back to this instant (for the controller's trials)."""
        return Snapshot(self._save(), self.rest.copy(), self.last_length.copy(), tuple(self.pending), self.time)

    def restore(self, snap: Snapshot) -> None:
        self._load(snap.engine)
        self.rest, self.last_length = snap.rest.copy(), snap.last_length.copy()
        self.pending, self.time = deque(snap.pending), snap.time

    def com(self) -> np.ndarray:
        """Centre of mass of the robot (3,) [m]."""
        _, _, com = self._poses()
        return self.masses @ com / self.masses.sum()

    def check(self) -> None:
        """Raise :class:`TestbedDiverged` if a node is NaN or faster than 30 m/s."""
        v = self.node_velocities()
        if not np.all(np.isfinite(v)) or np.abs(v).max() > _MAX_SPEED:
            raise TestbedDiverged(f"testbed diverged at t = {self.time:.3f} s (node speed {np.abs(v).max():.3g} m/s).")

    # ---------------------------------------------------------------- dynamics
    def _command(self, targets: np.ndarray) -> np.ndarray:
        """The targets the actuators act on now: those sent ``actuator_delay`` ago."""
        delay = int(round(self.effects.actuator_delay / self.dt))
        if delay == 0:
            return targets
        self.pending.append(targets)
        while len(self.pending) > delay + 1:
            self.pending.popleft()
        return self.pending[0]

    def _actuate(self, targets: np.ndarray, length: np.ndarray) -> None:
        """Basic actuator: target lengthened to keep tension <= maxTens, then L0 moves toward it
        by at most targetVelocity·dt; L0 >= 1 cm."""
        target = np.maximum(targets, length - self.theta["maxTens"] / self.k)
        step = self.theta["targetVelocity"] * self.dt
        self.rest = np.maximum(self.rest + np.clip(target - self.rest, -step, step), 0.01)

    def cable_forces(self, length: np.ndarray) -> np.ndarray:
        """Cable forces (24,) [N] >= 0: spring (softer while shortening with hysteresis) plus a
        damper clipped to the spring force; zero for a slack cable."""
        stretch = length - self.rest
        rate = (length - self.last_length) / self.dt
        spring = self.k * stretch * np.where(rate < 0, 1.0 - self.effects.hysteresis, 1.0)
        damper = np.clip(self.c * rate, -np.abs(spring), np.abs(spring))
        return np.where(stretch > 0, spring + damper, 0.0)

    def step(self, targets: np.ndarray) -> None:
        """One 1 ms step with 24 true target rest lengths [m]."""
        poses = self._poses()
        length, unit, anchors = self._cable_geometry(poses)
        self._actuate(self._command(np.asarray(targets, float)), length)
        force = self.cable_forces(length)[:, None] * unit
        self.last_length = length
        per_anchor = np.stack([force, -force], axis=1)            # anchor a pulled toward b
        rods = CABLE_ENDS // 2
        com = poses[2]
        net, torque = np.zeros((6, 3)), np.zeros((6, 3))
        np.add.at(net, rods, per_anchor)
        np.add.at(torque, rods, np.cross(anchors - com[rods], per_anchor))
        self._node_forces(poses, net, torque)
        self._advance(net, torque, com)
        self.time += self.dt

    def _node_forces(self, poses, net: np.ndarray, torque: np.ndarray) -> None:
        """Add air drag and ground viscosity, forces at the rod ends, to the rods' net wrenches."""
        eff = self.effects
        if eff.drag == 0 and eff.ground_viscosity == 0:
            return
        com = poses[2]
        nodes, vel = self.nodes(poses), self.node_velocities(poses)
        force = -eff.drag * vel
        if eff.ground_viscosity > 0:
            n = eff.ground_normal()
            near = (nodes @ n) < self.theta["radius"] + _NEAR_GROUND
            tangential = vel - np.outer(vel @ n, n)
            force -= eff.ground_viscosity * tangential * near[:, None]
        rods = np.arange(12) // 2
        np.add.at(net, rods, force)
        np.add.at(torque, rods, np.cross(nodes - com[rods], force))
