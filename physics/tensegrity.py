"""The T6 (SUPERball) tensegrity in DART: six rigid rods, 24 cables, 24 cable motors, ground.

Built from any θ of :meth:`ParameterSpace.t6` (15 parameters, SI). What each parameter does:

- ``density, radius, density_mp, radius_mp, rod_length, rod_length_mp``: mass and inertia of each
  rod as three coaxial cylinders (:func:`physics.geometry.rod_mass_properties`); ``radius`` is
  also the radius of the spherical contact caps at the rod ends;
- ``rod_length, rod_space``: node geometry, so build cable lengths L_build and rest lengths;
- ``stiffnessActive, damping``: cable spring-damper k, c (:mod:`physics.cables`);
- ``pretension``: build rest lengths L0_build = L_build - pretension / k;
- ``maxTens, targetVelocity, motor_radius, motor_friction, motor_inertia``: the motor model
  (:mod:`physics.actuators`).

The rods are six FreeJoint bodies of one Skeleton (origin = centre of mass, local z = rod axis);
one Skeleton keeps the Python side to one get/set call per step (six Skeletons made contacts
cheaper inside DART but cost more in Python calls, and were slower overall). A sphere of radius ``radius`` at
each node gives contact with a static ground box (ODE collision detector; FCL sinks cylinders).
Rods do not collide with each other (DART's self-collision check is off: it made each step
markedly slower); in the motions this model is for, caps of different rods stay a cable length apart. The middle of a rod has no collision shape: with the end radius
larger than the middle radius, a rod lying on the ground touches it with its caps. Deactivation
(sleeping) is off: it freezes resting bodies.

The robot is built with a closed face (three nodes joined by cables) facing the ground, dropped
from ``drop_height`` and settled with the motors holding their build rest lengths.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import dartpy as dart
import numpy as np

from physics.actuators import MotorGains, motor_step
from physics.cables import cable_energy, cable_wrenches, node_kinematics
from physics.errors import ParameterError, PhysicsError
from physics.geometry import (
    CABLE_NODES, N_CABLES, closed_faces, node_positions, rod_mass_properties, rotation_onto_face,
)
from physics.parameters import ParameterSpace

__all__ = ["ModelOptions", "RobotState", "T6Model", "rod_poses_from_nodes"]

_SPACE = ParameterSpace.t6()
_FACES = closed_faces()


@dataclass(frozen=True)
class ModelOptions:
    """Options of the T6 model that are not identified parameters.

    dt: physics step [s]; gravity [m/s^2] (0 switches it off); ground: whether the ground exists;
    friction: Coulomb coefficient rod-ground; spin_damping: axial damper of each rod [N m s]
    (see physics.cables; applied semi-implicitly, c / (1 + c dt / I_axial), so it is stable for
    any value; 2.0 stops a spin within ~5 ms, which keeps the unobservable spin small); drop_height: gap between the lowest cap and the ground at build [m];
    face: which of the 8 closed faces faces the ground at build (0..7); max_speed: a node faster
    than this [m/s] means the simulation diverged; motor: gains of the motor drivers.
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


def rod_poses_from_nodes(nodes: np.ndarray, node_velocities: np.ndarray | None = None):
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


def build_rest_lengths(params: Mapping[str, float]) -> np.ndarray:
    """L0_build = L_build - pretension / k for each cable (24,) [m], from geometry and θ."""
    nodes = node_positions(params["rod_length"], params["rod_space"])
    lengths = np.linalg.norm(nodes[CABLE_NODES[:, 1]] - nodes[CABLE_NODES[:, 0]], axis=1)
    rest = lengths - params["pretension"] / params["stiffnessActive"]
    if np.any(rest <= 0):
        raise ParameterError(
            f"pretension / stiffnessActive = {params['pretension'] / params['stiffnessActive']:.3f} m exceeds "
            f"the cable length {lengths.min():.3f} m: rest lengths would be <= 0. Lower the pretension."
        )
    return rest


class T6Model:
    """A DART world holding the SUPERball at parameters θ.

    >>> model = T6Model()                      # nominal θ, resting on a face after ``settle()``
    >>> model.settle(2.0); model.com()[2]      # doctest: +SKIP

    ``step(command)`` advances one physics step; ``command`` is 24 target rest lengths [m] as the
    robot's encoders read them (see physics.actuators), or None to keep the previous targets.
    """

    def __init__(self, theta: "np.ndarray | Mapping[str, float] | None" = None, *,
                 space: ParameterSpace | None = None, options: ModelOptions | None = None,
                 check_bounds: bool = False) -> None:
        self.space = space or _SPACE
        if self.space.names != _SPACE.names:
            raise ParameterError(
                f"T6Model needs the 15 T6 parameters in the order {list(_SPACE.names)}, got {list(self.space.names)}."
            )
        self.options = options or ModelOptions()
        self.theta = self.space.as_array(theta, check_bounds=check_bounds)
        if self.theta.ndim != 1:
            raise ParameterError(f"T6Model takes one θ of shape (15,), got {self.theta.shape}.")
        self.params = dict(zip(self.space.names, self.theta.tolist()))
        p = self.params
        self.mass_properties = rod_mass_properties(
            p["density"], p["radius"], p["density_mp"], p["radius_mp"], p["rod_length"], p["rod_length_mp"])
        self.half_lengths = np.full(6, 0.5 * p["rod_length"])
        self.end_a = np.ascontiguousarray(CABLE_NODES[:, 0])
        self.end_b = np.ascontiguousarray(CABLE_NODES[:, 1])
        self.build_rest_length = build_rest_lengths(p)
        self.encoder_zero = build_rest_lengths(dict(zip(self.space.names, self.space.nominal.tolist())))
        self.encoder_offset = self.build_rest_length - self.encoder_zero
        c_spin = self.options.spin_damping
        self._spin_coefficient = c_spin / (1.0 + c_spin * self.options.dt / self.mass_properties.axial)
        self._forces = np.zeros(36)
        self._tension = np.zeros(N_CABLES)
        self._length = np.zeros(N_CABLES)
        self._build_world()
        self.reset()

    # ------------------------------------------------------------------ construction
    def _build_world(self) -> None:
        opt, p, mp = self.options, self.params, self.mass_properties
        world = dart.simulation.World()
        world.setTimeStep(opt.dt)
        world.setGravity([0.0, 0.0, -opt.gravity])
        world.setCollisionDetector(dart.collision.OdeCollisionDetector())
        deact = world.getDeactivationOptions()
        deact.mEnabled = False
        world.setDeactivationOptions(deact)
        robot = dart.dynamics.Skeleton("t6")
        for i in range(6):
            joint, body = robot.createFreeJointAndBodyNodePair(None)
            joint.setName(f"rod{i}_joint")
            body.setName(f"rod{i}")
            body.setMass(mp.mass)
            body.setMomentOfInertia(mp.transverse, mp.transverse, mp.axial, 0.0, 0.0, 0.0)
            for sign in (-1.0, 1.0):
                cap = body.createShapeNode(dart.dynamics.SphereShape(p["radius"]))
                cap.setRelativeTranslation([0.0, 0.0, sign * 0.5 * p["rod_length"]])
                cap.createCollisionAspect()
                cap.createDynamicsAspect().setFrictionCoeff(opt.friction)
                cap.getDynamicsAspect().setRestitutionCoeff(0.0)
        world.addSkeleton(robot)
        if opt.ground:
            ground = dart.dynamics.Skeleton("ground")
            _, gbody = ground.createWeldJointAndBodyNodePair(None)
            box = gbody.createShapeNode(dart.dynamics.BoxShape([100.0, 100.0, 1.0]))
            box.setRelativeTranslation([0.0, 0.0, -0.5])
            box.createCollisionAspect()
            box.createDynamicsAspect().setFrictionCoeff(opt.friction)
            box.getDynamicsAspect().setRestitutionCoeff(0.0)
            ground.setMobile(False)
            world.addSkeleton(ground)
        self.world, self.robot = world, robot

    def initial_nodes(self) -> np.ndarray:
        """Node positions (12 x 3) at build: chosen face down, lowest cap ``drop_height`` above ground."""
        p = self.params
        nodes = node_positions(p["rod_length"], p["rod_space"])
        nodes = nodes @ rotation_onto_face(nodes, _FACES[self.options.face]).T
        nodes[:, :2] -= nodes[:, :2].mean(axis=0)
        if self.options.ground:
            nodes[:, 2] += p["radius"] + self.options.drop_height - nodes[:, 2].min()
        return nodes

    def reset(self) -> None:
        """Back to the build configuration: at rest, rest lengths = L0_build, motors still."""
        q, dq = rod_poses_from_nodes(self.initial_nodes())
        self._set_positions(q)
        self._set_velocities(dq)
        self.world.setTime(0.0)
        self.rest_length = self.build_rest_length.copy()
        self.motor_speed = np.zeros(N_CABLES)
        self.target = self.build_rest_length.copy()
        self._update_cables()

    # ------------------------------------------------------------------ raw DART state
    def _positions(self) -> np.ndarray:
        """FreeJoint positions of the six rods (36,): per rod [rotation vector, centre]."""
        return self.robot.getPositions()

    def _velocities(self) -> np.ndarray:
        """FreeJoint velocities (36,): per rod [world ω, world v of the centre]."""
        return self.robot.getVelocities()

    def _set_positions(self, q: np.ndarray) -> None:
        self.robot.setPositions(q)

    def _set_velocities(self, dq: np.ndarray) -> None:
        self.robot.setVelocities(dq)

    # ------------------------------------------------------------------ stepping
    def _update_cables(self) -> float:
        """Recompute cable forces; returns the largest squared node speed (NaN if not finite)."""
        return cable_wrenches(self.robot.getPositions(), self.robot.getVelocities(), self.half_lengths,
                       self.end_a, self.end_b, self.rest_length, self.params["stiffnessActive"],
                       self.params["damping"], self._spin_coefficient,
                       self._forces, self._tension, self._length)

    def command(self, target_readings: np.ndarray | None) -> None:
        """Set the motor targets from rest lengths as the encoders read them (24,) [m]."""
        if target_readings is None:
            return
        target = np.asarray(target_readings, dtype=float)
        if target.shape != (N_CABLES,) or not np.all(np.isfinite(target)):
            raise PhysicsError(f"command must be 24 finite target rest lengths [m], got shape {target.shape}.")
        self.target = target + self.encoder_offset

    def step(self, target_readings: np.ndarray | None = None, n: int = 1) -> None:
        """Advance ``n`` physics steps of ``dt`` with the given motor targets (encoder metres)."""
        self.command(target_readings)
        p, gains = self.params, self.options.motor
        motor = (p["maxTens"], p["targetVelocity"], p["motor_radius"], p["motor_friction"], p["motor_inertia"],
                 gains.kp, gains.kv, gains.min_rest_length, self.options.dt)
        world, robot, forces = self.world, self.robot, self._forces
        limit = self.options.max_speed ** 2
        for _ in range(n):
            if not self._update_cables() <= limit:
                self.check()   # raises PhysicsError before DART sees absurd coordinates
            robot.setForces(forces)
            world.step()
            motor_step(self.rest_length, self.motor_speed, self.target, self._tension, *motor)
        if not self._update_cables() <= limit:
            self.check()

    def check(self) -> None:
        """Raise :class:`PhysicsError` if the state is not finite or a node moves too fast.

        ``step`` runs this guard at every physics step (from the node speeds the cable kernel
        computes anyway), so an exploding state never reaches the collision detector, which
        aborts the process on huge coordinates."""
        v = self.node_velocities()
        if not (np.all(np.isfinite(self._positions())) and np.all(np.isfinite(v))):
            raise PhysicsError(f"Simulation diverged at t = {self.time:.3f} s: non-finite state. "
                               "Reduce dt or check θ for extreme values.")
        speed = float(np.sqrt((v**2).sum(axis=1)).max())
        if speed > self.options.max_speed:
            raise PhysicsError(f"Simulation diverged at t = {self.time:.3f} s: a node moves at {speed:.1f} m/s "
                               f"(> max_speed = {self.options.max_speed} m/s). Reduce dt or check θ.")

    def settle(self, duration: float = 2.0) -> None:
        """Simulate ``duration`` seconds holding the current targets (drop and come to rest)."""
        self.step(None, n=int(round(duration / self.options.dt)))

    # ------------------------------------------------------------------ state
    @property
    def time(self) -> float:
        return float(self.world.getTime())

    def get_state(self) -> RobotState:
        return RobotState(self._positions(), self._velocities(),
                          self.rest_length.copy(), self.motor_speed.copy(), self.target.copy(), self.time)

    def set_state(self, state: RobotState) -> None:
        self._set_positions(state.positions)
        self._set_velocities(state.velocities)
        self.rest_length = np.array(state.rest_length, dtype=float)
        self.motor_speed = np.array(state.motor_speed, dtype=float)
        self.target = np.array(state.target, dtype=float)
        self.world.setTime(state.time)
        self._update_cables()

    def set_nodes(self, nodes: np.ndarray, node_velocities: np.ndarray | None = None) -> None:
        """Place the rods at observed node positions (12 x 3) and velocities (12 x 3)."""
        q, dq = rod_poses_from_nodes(np.asarray(nodes, float),
                                     None if node_velocities is None else np.asarray(node_velocities, float))
        self._set_positions(q)
        self._set_velocities(dq)
        self._update_cables()

    # ------------------------------------------------------------------ observations
    def node_positions(self) -> np.ndarray:
        """Rod endpoints in world coordinates (12 x 3) [m]."""
        return node_kinematics(self._positions(), self._velocities(), self.half_lengths)[0]

    def node_velocities(self) -> np.ndarray:
        return node_kinematics(self._positions(), self._velocities(), self.half_lengths)[1]

    def tensions(self) -> np.ndarray:
        """Cable tensions (24,) [N], always >= 0."""
        return self._tension.copy()

    def cable_lengths(self) -> np.ndarray:
        return self._length.copy()

    def rest_length_readings(self) -> np.ndarray:
        """Rest lengths as the encoders read them (24,) [m]."""
        return self.rest_length - self.encoder_offset

    def com(self) -> np.ndarray:
        """Centre of mass (3,) [m] (all rods have the same mass)."""
        return self._positions().reshape(6, 6)[:, 3:].mean(axis=0)

    def energy(self) -> dict[str, float]:
        """Kinetic, gravitational and elastic energy [J] and their sum ``total``."""
        kinetic = float(self.robot.computeKineticEnergy())
        gravity = float(self.mass_properties.mass * 6 * self.options.gravity * self.com()[2])
        elastic = cable_energy(self._length, self.rest_length, self.params["stiffnessActive"])
        return {"kinetic": kinetic, "gravity": gravity, "elastic": elastic,
                "total": kinetic + gravity + elastic}
