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

The options' two constants with a mass in their unit (the rods' spin damping, the motor driver's
speed gain K_v) are applied times the mass scale s(θ) = M_rods(θ) / M_rods(θ_nominal)
(``mass_scale``, :func:`physics.scaling.rod_mass_scale`), so that every mass and force times λ gives
the same motion (the symmetry of :mod:`physics.scaling` is exact).

The rods are six FreeJoint bodies of one Skeleton (origin = centre of mass, local z = rod axis);
one Skeleton keeps the Python side to one get/set call per step (six Skeletons made contacts
cheaper inside DART but cost more in Python calls, and were slower overall). A sphere of radius ``radius`` at
each node gives contact with a static ground box (ODE collision detector; FCL sinks cylinders).
Rods do not collide with each other (DART's self-collision check is off: it made each step
markedly slower); in the motions this model is for, caps of different rods stay a cable length
apart. The middle of a rod has no collision shape: with the end radius larger than the middle
radius, a rod lying on the ground touches it with its caps. Deactivation
(sleeping) is off: it freezes resting bodies.

The robot is built with a closed face (three nodes joined by cables) facing the ground, dropped
from ``drop_height`` and settled with the motors holding their build rest lengths.

Effects (physics.effects) extend the model: ``T6Model(θ, effects=[...])`` takes θ in
``model_space(effects)`` (the 15 T6 parameters, then the effects'), and each effect edits the
:class:`~physics.effects.ModelSetup` the world is built and stepped from (gravity vector, cap
radius and shape, point masses, cable law, actuator, command delay, extra node forces and rod
wrenches, the rods' spin damping and orientation, observation offset).
"""
from __future__ import annotations

from collections import deque
from collections.abc import Mapping, Sequence

import dartpy as dart
import numpy as np

from physics.cables import add_node_forces, cable_energy, cable_wrenches, node_kinematics
from physics.effects.base import Effect, ModelSetup, model_space, split_theta
from physics.errors import ParameterError, PhysicsError
from physics.geometry import (
    CABLE_NODES,
    N_CABLES,
    closed_faces,
    node_positions,
    rod_mass_properties,
    rod_poses_from_nodes,
    rotation_between,
    rotation_onto_face,
)
from physics.model_options import ModelOptions, RobotState
from physics.parameters import ParameterSpace
from physics.scaling import rod_mass_scale

__all__ = ["ModelOptions", "RobotState", "T6Model", "rod_poses_from_nodes"]

_SPACE = ParameterSpace.t6()
_FACES = closed_faces()


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

    def __init__(self, theta: np.ndarray | Mapping[str, float] | None = None, *,
                 space: ParameterSpace | None = None, options: ModelOptions | None = None,
                 check_bounds: bool = False, effects: Sequence[Effect] = ()) -> None:
        self.effects = tuple(effects)
        expected = model_space(self.effects)
        self.space = space or expected
        if self.space.names != expected.names:
            raise ParameterError(
                f"T6Model needs the T6 parameters and those of effects {[e.name for e in self.effects]}: "
                f"{list(expected.names)} in this order, got {list(self.space.names)}; build the space "
                "with physics.effects.model_space(effects)."
            )
        self.options = options or ModelOptions()
        self.theta = self.space.as_array(theta, check_bounds=check_bounds)
        if self.theta.ndim != 1:
            raise ParameterError(f"T6Model takes one θ of shape ({self.space.dim},), got {self.theta.shape}.")
        self.params, self.effect_values = split_theta(self.theta, self.space, self.effects, _SPACE.dim)
        p = self.params
        self.mass_scale = rod_mass_scale(p)       # s(θ): the options' constants of mass dimension scale with it
        self.setup = ModelSetup.base(p, self.options.gravity, self.options.motor_at(self.mass_scale), self.options.dt)
        for effect, values in zip(self.effects, self.effect_values, strict=True):
            effect.apply(self.setup, values, p)
        self.mass_properties = rod_mass_properties(
            p["density"], p["radius"], p["density_mp"], p["radius_mp"], p["rod_length"], p["rod_length_mp"])
        self.half_lengths = np.full(6, 0.5 * p["rod_length"])
        self.end_a = np.ascontiguousarray(CABLE_NODES[:, 0])
        self.end_b = np.ascontiguousarray(CABLE_NODES[:, 1])
        self.build_rest_length = build_rest_lengths(p)
        self.encoder_zero = build_rest_lengths(dict(zip(self.space.names, self.space.nominal.tolist(), strict=True)))
        self.encoder_offset = self.build_rest_length - self.encoder_zero
        c_spin = (self.options.spin_damping_at(self.mass_scale) if self.setup.spin_damping is None
                  else self.setup.spin_damping)
        self._spin_coefficient = c_spin / (1.0 + c_spin * self.options.dt / self.mass_properties.axial)
        self._cable_args = self.setup.cable.args()
        self._pending: deque = deque()
        self._node_forces = np.zeros((12, 3))
        self._forces = np.zeros(36)
        self._tension = self.setup.tension        # written in place each step; effects' terms read it
        self._length = np.zeros(N_CABLES)
        self._build_world()
        self.reset()

    # ------------------------------------------------------------------ construction
    def _build_world(self) -> None:
        opt, p = self.options, self.params
        world = dart.simulation.World()
        world.setTimeStep(opt.dt)
        world.setGravity(self.setup.gravity)
        world.setCollisionDetector(dart.collision.OdeCollisionDetector())
        deact = world.getDeactivationOptions()
        deact.mEnabled = False
        world.setDeactivationOptions(deact)
        robot = dart.dynamics.Skeleton("t6")
        for i in range(6):
            joint, body = robot.createFreeJointAndBodyNodePair(None)
            joint.setName(f"rod{i}_joint")
            body.setName(f"rod{i}")
            self._set_inertia(body, i)
            for sign in (-1.0, 1.0):
                cap = body.createShapeNode(self._cap_shape())
                cap.setRelativeTranslation([0.0, 0.0, sign * 0.5 * (p["rod_length"] - self.setup.cap_length)])
                cap.createCollisionAspect()
                cap.createDynamicsAspect().setFrictionCoeff(opt.friction)
                cap.getDynamicsAspect().setRestitutionCoeff(0.0)
        world.addSkeleton(robot)
        if opt.ground:
            ground = dart.dynamics.Skeleton("ground")
            joint, gbody = ground.createWeldJointAndBodyNodePair(None)
            pose = dart.math.Isometry3()          # the box's top face: the plane through 0 normal to ground_normal
            pose.set_rotation(rotation_between(np.array([0.0, 0.0, 1.0]), self.setup.ground_normal))
            joint.setTransformFromParentBodyNode(pose)
            box = gbody.createShapeNode(dart.dynamics.BoxShape([100.0, 100.0, 1.0]))
            box.setRelativeTranslation([0.0, 0.0, -0.5])
            box.createCollisionAspect()
            box.createDynamicsAspect().setFrictionCoeff(opt.friction)
            box.getDynamicsAspect().setRestitutionCoeff(0.0)
            ground.setMobile(False)
            world.addSkeleton(ground)
        self.world, self.robot = world, robot

    def _cap_shape(self) -> dart.dynamics.Shape:
        """A sphere of the contact radius centred on the node, or (``setup.cap_length`` > 0) a cylinder
        of that radius and length whose outer face is centred on the node."""
        if self.setup.cap_length > 0:
            return dart.dynamics.CylinderShape(self.setup.cap_radius, self.setup.cap_length)
        return dart.dynamics.SphereShape(self.setup.cap_radius)

    def _set_inertia(self, body: dart.dynamics.BodyNode, rod: int) -> None:
        """Mass, inertia about the centre of mass and its offset along the axis, with point masses
        m_k at z_k: M' = M + Σm_k, z_c = Σ m_k z_k / M', I_t' = I_t + M z_c² + Σ m_k (z_k - z_c)²."""
        mp = self.mass_properties
        extra = [(m, z) for r, m, z in self.setup.point_masses if r == rod]
        mass = mp.mass + sum(m for m, _ in extra)
        z_c = sum(m * z for m, z in extra) / mass
        transverse = mp.transverse + mp.mass * z_c**2 + sum(m * (z - z_c) ** 2 for m, z in extra)
        body.setMass(mass)
        body.setMomentOfInertia(transverse, transverse, mp.axial, 0.0, 0.0, 0.0)
        body.setLocalCOM([0.0, 0.0, z_c])

    def initial_nodes(self) -> np.ndarray:
        """Node positions (12 x 3) at build: chosen face down, lowest cap ``drop_height`` above ground."""
        p = self.params
        nodes = node_positions(p["rod_length"], p["rod_space"])
        nodes = nodes @ rotation_onto_face(nodes, _FACES[self.options.face]).T
        nodes[:, :2] -= nodes[:, :2].mean(axis=0)
        if self.options.ground:               # lift along z until the lowest cap is drop_height off the floor
            n = self.setup.ground_normal
            nodes[:, 2] += (self.setup.cap_radius + self.options.drop_height - (nodes @ n).min()) / n[2]
        return nodes

    def reset(self) -> None:
        """Back to the build configuration: at rest, rest lengths = L0_build, motors still."""
        self._place(self.initial_nodes(), None)
        self.world.setTime(0.0)
        self.rest_length = self.build_rest_length.copy()
        self.motor_speed = np.zeros(N_CABLES)
        self.target = self.build_rest_length.copy()
        self._pending.clear()
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
        """Recompute cable forces (plus the effects' node forces); returns the largest squared node
        speed (NaN if not finite)."""
        q, dq = self.robot.getPositions(), self.robot.getVelocities()
        fastest = cable_wrenches(q, dq, self.half_lengths, self.end_a, self.end_b, self.rest_length,
                                 *self._cable_args, self._spin_coefficient, self._forces, self._tension, self._length)
        if self.setup.force_terms:
            nodes, velocities, axes = node_kinematics(q, dq, self.half_lengths)
            extra = self._node_forces
            extra[:] = 0.0
            for term in self.setup.force_terms:
                term(nodes, velocities, extra)
            add_node_forces(axes, self.half_lengths, extra, self._forces)
        for wrench in self.setup.wrench_terms:
            wrench(q, dq, self._forces)
        for contact in self.setup.contact_terms:     # last: they read the whole applied wrench
            contact(q, dq, self._forces)
        return fastest

    def command(self, target_readings: np.ndarray | None, reference: str = "encoder") -> None:
        """Send motor targets (24,) [m]: rest lengths as the encoders read them (``reference=
        "encoder"``) or true rest lengths (``"true"``). With a command delay τ the actuators see
        them τ seconds later."""
        if target_readings is None:
            return
        target = np.asarray(target_readings, dtype=float)
        if target.shape != (N_CABLES,) or not np.all(np.isfinite(target)):
            raise PhysicsError(f"command must be 24 finite target rest lengths [m], got shape {target.shape}.")
        target = (target + self.encoder_offset if reference == "encoder" else target) + self.setup.command_offset
        if self.setup.command_delay > 0:
            self._pending.append((self.time + self.setup.command_delay, target))
        else:
            self.target = target

    def prime_commands(self, times: np.ndarray, targets: np.ndarray, reference: str = "encoder") -> None:
        """Load the commands sent at ``times`` (k,) [s] <= now, targets (k x 24), into the delay line:
        the latest one due before now becomes the current target, later ones stay pending."""
        self._pending.clear()
        self.target = self.build_rest_length.copy()
        delay, now = self.setup.command_delay, self.time
        offset = (self.encoder_offset if reference == "encoder" else 0.0) + self.setup.command_offset
        for t, target in zip(times, targets, strict=True):
            if t + delay <= now + 1e-9:
                self.target = np.asarray(target, float) + offset
            else:
                self._pending.append((float(t) + delay, np.asarray(target, float) + offset))

    def step(self, target_readings: np.ndarray | None = None, n: int = 1, reference: str = "encoder") -> None:
        """Advance ``n`` physics steps of ``dt`` with the given motor targets (see :meth:`command`)."""
        self.command(target_readings, reference)
        world, robot, forces, actuator = self.world, self.robot, self._forces, self.setup.actuator
        limit, pending = self.options.max_speed ** 2, self._pending
        for _ in range(n):
            while pending and pending[0][0] <= world.getTime() + 1e-9:
                self.target = pending.popleft()[1]
            if not self._update_cables() <= limit:
                self.check()   # raises PhysicsError before DART sees absurd coordinates
            robot.setForces(forces)
            world.step()
            actuator.step(self.rest_length, self.motor_speed, self.target, self._tension)
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
        self._place(np.asarray(nodes, float), None if node_velocities is None else np.asarray(node_velocities, float))
        self._update_cables()

    def _place(self, nodes: np.ndarray, node_velocities: np.ndarray | None) -> None:
        """Rods at node positions and velocities (12 x 3 each; no spin about their axes), turned
        about their axes by the effects' ``orient`` if one is set."""
        q, dq = rod_poses_from_nodes(nodes, node_velocities)
        if self.setup.orient is not None:
            q = self.setup.orient(q)
        self._set_positions(q)
        self._set_velocities(dq)

    # ------------------------------------------------------------------ observations
    def node_positions(self) -> np.ndarray:
        """Rod endpoints in world coordinates (12 x 3) [m]."""
        return node_kinematics(self._positions(), self._velocities(), self.half_lengths)[0]

    def node_velocities(self) -> np.ndarray:
        return node_kinematics(self._positions(), self._velocities(), self.half_lengths)[1]

    def observe(self, nodes: np.ndarray) -> np.ndarray:
        """What the sensors report for true node positions (... x 12 x 3): nodes + observation offset."""
        return nodes + self.setup.observation_offset

    def unobserve(self, observed: np.ndarray) -> np.ndarray:
        """True node positions behind observed ones (the inverse of :meth:`observe`)."""
        return observed - self.setup.observation_offset

    def tensions(self) -> np.ndarray:
        """Cable tensions (24,) [N], always >= 0."""
        return self._tension.copy()

    def cable_lengths(self) -> np.ndarray:
        return self._length.copy()

    def rest_length_readings(self) -> np.ndarray:
        """Rest lengths as the encoders read them (24,) [m]."""
        return self.rest_length - self.encoder_offset

    def com(self) -> np.ndarray:
        """Centre of mass (3,) [m] of the six rods (with any point masses)."""
        return np.asarray(self.robot.getCOM(), float)

    def energy(self) -> dict[str, float]:
        """Kinetic, gravitational (-M g⃗·c) and elastic energy [J] and their sum ``total``."""
        kinetic = float(self.robot.computeKineticEnergy())
        gravity = float(-self.robot.getMass() * self.setup.gravity @ self.com())
        cable = self.setup.cable
        elastic = cable_energy(self._length, self.rest_length, cable.stiffness, cable.quadratic)
        return {"kinetic": kinetic, "gravity": gravity, "elastic": elastic,
                "total": kinetic + gravity + elastic}
