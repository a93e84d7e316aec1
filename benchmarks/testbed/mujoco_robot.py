"""The testbed SUPERball in MuJoCo: a third engine, held back from the mismatch stage's development.

The robot's own side (cables, actuators, payload, effects) is :class:`testbed.cable_robot.CableRobot`,
the same as in Bullet; MuJoCo's side is written the way a MuJoCo user would write it, with the
engine's defaults where the robot does not say otherwise (docs/third-engine.md):

- each rod is one free body whose shapes are capsules ``fromto`` its nodes: the end segments
  (radius ``radius``) have a hemisphere centred on each node, so a node rests ``radius`` above a
  level floor whatever the rod's tilt; the middle segment has radius ``radius_mp``;
- MuJoCo's soft contact with its default solver parameters (solref 0.02 s, solimp 0.9-0.95),
  pyramidal friction cones, sliding friction 0.5 and no rolling or torsional friction
  (condim 3); rods collide with each other and with the plane;
- the ``implicitfast`` integrator at 1 ms; the cables, payload forces and drag are applied at the
  centres of mass through ``xfrc_applied``; gravity −9.81 along world z.
"""
from __future__ import annotations

import mujoco
import numpy as np

from testbed.cable_robot import CableRobot, RodBody, rotation_between

__all__ = ["MujocoRobot"]

_FRICTION = 0.5


def _quat_wxyz(rot: np.ndarray) -> str:
    """MuJoCo's quaternion text (w x y z) of a rotation matrix (3 x 3)."""
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rot, float).ravel())
    return " ".join(f"{v:.17g}" for v in q)


def _vec(v) -> str:
    return " ".join(f"{float(x):.17g}" for x in v)


class MujocoRobot(CableRobot):
    """The SUPERball at parameters ``theta`` with ``effects``, in its own MuJoCo model and data."""

    __test__ = False
    engine, engine_name = "mujoco", "MuJoCo"

    def _make_world(self, rods: list[RodBody]) -> None:
        self.model = mujoco.MjModel.from_xml_string(self._xml(rods))
        self.data = mujoco.MjData(self.model)
        self.body_ids = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, f"rod{i}") for i in range(6)]
        adr = self.model.jnt_dofadr[self.model.body_jntadr[self.body_ids]]
        self._dofs = adr[:, None] + np.arange(6)
        mujoco.mj_forward(self.model, self.data)
        self._state_spec = mujoco.mjtState.mjSTATE_INTEGRATION

    def _xml(self, rods: list[RodBody]) -> str:
        """The MJCF text of the ground and the six rods (module docstring)."""
        th = self.theta
        h, l_end = 0.5 * th["rod_length"], 0.5 * (th["rod_length"] - th["rod_length_mp"])
        ground = rotation_between(np.array([0.0, 0.0, 1.0]), self.effects.ground_normal())
        bodies = []
        for i, rod in enumerate(rods):
            caps = "".join(f'<geom type="capsule" size="{r:.17g}" fromto="0 0 {a:.17g} 0 0 {b:.17g}"/>'
                           for r, a, b in ((th["radius"], -h, -h + l_end), (th["radius_mp"], -h + l_end, h - l_end),
                                           (th["radius"], h - l_end, h)))
            bodies.append(
                f'<body name="rod{i}" pos="{_vec(rod.centre)}" quat="{_quat_wxyz(rod.rotation)}"><freejoint/>'
                f'<inertial pos="0 0 {rod.com_along:.17g}" mass="{rod.mass:.17g}" '
                f'diaginertia="{rod.transverse:.17g} {rod.transverse:.17g} {rod.axial:.17g}"/>{caps}</body>')
        return (f'<mujoco model="superball"><option timestep="{self.dt:.17g}" integrator="implicitfast" '
                f'gravity="0 0 -9.81"/><default><geom condim="3" friction="{_FRICTION} 0.005 0.0001" '
                f'density="0"/></default><worldbody>'
                f'<geom name="ground" type="plane" size="0 0 1" quat="{_quat_wxyz(ground)}"/>'
                + "".join(bodies) + "</worldbody></mujoco>")

    def _body_states(self) -> tuple[np.ndarray, np.ndarray]:
        ids = self.body_ids
        return self.data.xmat[ids].reshape(6, 3, 3).copy(), self.data.xipos[ids].copy()

    def _body_velocities(self) -> tuple[np.ndarray, np.ndarray]:
        """From the free joints' velocities: the body origin's velocity in the world frame and the
        angular velocity in the body frame, moved to the centre of mass and the world frame."""
        qvel = self.data.qvel[self._dofs]                         # (6, 6)
        rot = self.data.xmat[self.body_ids].reshape(6, 3, 3)
        w = np.einsum("iab,ib->ia", rot, qvel[:, 3:])
        arm = self.data.xipos[self.body_ids] - self.data.xpos[self.body_ids]
        return qvel[:, :3] + np.cross(w, arm), w

    def _advance(self, net: np.ndarray, torque: np.ndarray, com: np.ndarray) -> None:
        """Step with the wrenches, then bring the bodies' poses up to the new state (mj_step leaves
        them at the state it started from)."""
        self.data.xfrc_applied[self.body_ids] = np.hstack([net, torque])
        mujoco.mj_step(self.model, self.data)
        mujoco.mj_kinematics(self.model, self.data)

    def _save(self) -> np.ndarray:
        state = np.empty(mujoco.mj_stateSize(self.model, self._state_spec))
        mujoco.mj_getState(self.model, self.data, state, self._state_spec)
        return state

    def _load(self, state: object) -> None:
        mujoco.mj_setState(self.model, self.data, np.asarray(state), self._state_spec)
        mujoco.mj_forward(self.model, self.data)
