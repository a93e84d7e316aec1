"""The testbed SUPERball in Bullet: six compound rods on Bullet's ground plane.

The robot's own side (cables, actuators, payload, effects) is :class:`testbed.cable_robot.CableRobot`;
Bullet's side, the testbed's modelling choices (docs/testbed.md lists them all):

- each rod is one Bullet body made of three coaxial cylinder shapes (end, middle, end); the end
  cylinders are the contact shapes (flat ends, no spheres), so a node (the centre of a rod's end
  face) rests ``radius`` above a level floor;
- the cables are forces applied at the centres of mass each step; anchors on the rims resist a
  rod's spin about its own axis, so no extra spin damper is needed;
- Bullet's ground plane, lateral friction 0.5 (rod 0.5 × ground 1.0), rolling friction 0.01 on
  the rods and 1.0 on the ground (``ground_rolling``): Bullet combines a pair's rolling friction
  as r_a f_b + r_b f_a, so a cap on the ground has 0.01 × 1.0 + 1.0 × 0.5 = 0.51 [m]; restitution
  0, time step 1 ms, gravity −9.81 along world z.
"""
from __future__ import annotations

import numpy as np
import pybullet as pb

from testbed.cable_robot import (
    CableRobot,
    RodBody,
    Snapshot,
    TestbedDiverged,
    build_pose,
    encoder_zero,
    rod_inertia,
    rotation_between,
)
from testbed.effects import Effects

__all__ = ["TestbedRobot", "TestbedDiverged", "Snapshot", "encoder_zero", "build_pose", "rod_inertia"]

_FRICTION, _ROLLING, _GRAVITY = 0.5, 0.01, 9.81


def _quaternion(rot: np.ndarray) -> list[float]:
    """Quaternion (x, y, z, w) of a rotation matrix (3 x 3)."""
    w = np.sqrt(max(0.0, 1 + np.trace(rot))) / 2
    x = np.copysign(np.sqrt(max(0.0, 1 + rot[0, 0] - rot[1, 1] - rot[2, 2])) / 2, rot[2, 1] - rot[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1 - rot[0, 0] + rot[1, 1] - rot[2, 2])) / 2, rot[0, 2] - rot[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1 - rot[0, 0] - rot[1, 1] + rot[2, 2])) / 2, rot[1, 0] - rot[0, 1])
    return [x, y, z, w]


class TestbedRobot(CableRobot):
    """The SUPERball at parameters ``theta`` with ``effects``, in its own Bullet client;
    ``ground_rolling``: the ground's rolling friction (ablations only)."""

    __test__ = False     # not a pytest class, despite its name
    engine, engine_name = "bullet", "Bullet"

    def __init__(self, theta: dict[str, float], effects: Effects = Effects(), *, face: int = 0,
                 ground_rolling: float = 1.0) -> None:
        self.ground_rolling = float(ground_rolling)
        super().__init__(theta, effects, face=face)

    def _make_world(self, rods: list[RodBody]) -> None:
        self.client = pb.connect(pb.DIRECT)
        pb.setGravity(0, 0, -_GRAVITY, physicsClientId=self.client)
        pb.setTimeStep(self.dt, physicsClientId=self.client)
        self._ground()
        self._rods(rods)

    def _ground(self) -> None:
        shape = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=self.client)
        rot = rotation_between(np.array([0.0, 0.0, 1.0]), self.effects.ground_normal())
        self.ground = pb.createMultiBody(0, shape, baseOrientation=_quaternion(rot), physicsClientId=self.client)
        pb.changeDynamics(self.ground, -1, lateralFriction=1.0, restitution=0.0, rollingFriction=self.ground_rolling,
                          physicsClientId=self.client)

    def _rods(self, rods: list[RodBody]) -> None:
        """Create the six bodies: three coaxial cylinders each, inertia given."""
        th, cid = self.theta, self.client
        l_mp = th["rod_length_mp"]
        l_end = 0.5 * (th["rod_length"] - l_mp)
        z_end = 0.5 * (l_mp + l_end)
        self.bodies = []
        for rod in rods:
            shape = pb.createCollisionShapeArray(
                [pb.GEOM_CYLINDER] * 3, radii=[th["radius"], th["radius_mp"], th["radius"]],
                lengths=[l_end, l_mp, l_end], collisionFramePositions=[[0, 0, -z_end], [0, 0, 0], [0, 0, z_end]],
                physicsClientId=cid)
            body = pb.createMultiBody(rod.mass, shape, -1, rod.centre.tolist(), _quaternion(rod.rotation),
                                      baseInertialFramePosition=[0, 0, rod.com_along], physicsClientId=cid)
            pb.changeDynamics(body, -1, localInertiaDiagonal=[rod.transverse, rod.transverse, rod.axial],
                              lateralFriction=_FRICTION, restitution=0.0, rollingFriction=_ROLLING,
                              linearDamping=0.0, angularDamping=0.0, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING,
                              physicsClientId=cid)
            self.bodies.append(body)

    def _body_states(self) -> tuple[np.ndarray, np.ndarray]:
        rot, com = np.empty((6, 3, 3)), np.empty((6, 3))
        for i, body in enumerate(self.bodies):
            pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=self.client)
            rot[i] = np.reshape(pb.getMatrixFromQuaternion(orn), (3, 3))
            com[i] = pos
        return rot, com

    def _body_velocities(self) -> tuple[np.ndarray, np.ndarray]:
        v, w = np.empty((6, 3)), np.empty((6, 3))
        for i, body in enumerate(self.bodies):
            v[i], w[i] = pb.getBaseVelocity(body, physicsClientId=self.client)
        return v, w

    def _advance(self, net: np.ndarray, torque: np.ndarray, com: np.ndarray) -> None:
        for i, body in enumerate(self.bodies):
            pb.applyExternalForce(body, -1, net[i].tolist(), com[i].tolist(), pb.WORLD_FRAME, physicsClientId=self.client)
            pb.applyExternalTorque(body, -1, torque[i].tolist(), pb.WORLD_FRAME, physicsClientId=self.client)
        pb.stepSimulation(physicsClientId=self.client)

    def _save(self) -> int:
        return pb.saveState(physicsClientId=self.client)

    def _load(self, state: object) -> None:
        pb.restoreState(stateId=state, physicsClientId=self.client)

    def forget(self, snap: Snapshot) -> None:
        pb.removeState(snap.engine, physicsClientId=self.client)

    def close(self) -> None:
        pb.disconnect(physicsClientId=self.client)
