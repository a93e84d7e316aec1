"""The SUPERball rebuilt in MuJoCo with MuJoCo's own cables and winches: a robot that shares no robot code.

The Bullet testbed and :mod:`testbed.mujoco_robot` share one robot (``testbed.cable_robot``: NTRT's
cable law and tension-limited kinematic actuator, forces applied from Python). This robot shares
only the hardware's description (the 15 parameters and the node and cable layout of
``testbed.params``, the effects of ``testbed.effects``); everything that moves it is MJCF, written
as a MuJoCo user would write a cable robot with winches (MuJoCo >= 3.14 for ``pid``/``slewmax``/``delay``):

- **rods**: one free body each; its mass and inertia come from three coaxial cylinder geoms with
  the hardware's densities (ends: ``density``, ``radius``; middle: ``density_mp``, ``radius_mp``,
  ``rod_length_mp``), which do not collide; the contact shapes are capsules of the same radii
  with no mass, so a node (an end face's centre) carries a hemisphere of ``radius`` and rests
  ``radius`` above a level floor. A payload is a 1 mm sphere of ``extra_mass`` on the rod's axis.
- **cables**: 24 spatial tendons between sites on the end faces' rims (``radius`` from the node,
  toward the other end of the cable, perpendicular to the rod, fixed in the rod at the build pose).
  The tendon is the cable's path (its length and where its force acts), with no stiffness,
  damping or springlength of its own: a tendon's ``springlength`` is a constant of the model that
  no actuator moves, and a winch moves the rest length; and a tendon's ``damping`` acts on a slack
  cable too, pushing while it shortens. Its ``actuatorfrcrange`` [−maxTens, 0] clamps the sum of
  the forces below (MuJoCo scales them down together): a cable never pushes and never pulls
  harder than ``maxTens``.
- **winches**: one ``pid`` actuator per tendon, input ``pos``, force kp (u − L) with
  kp = ``stiffnessActive`` and u the effective setpoint: the cable's spring in series with a stiff
  spool whose position u is the rest length; while L < u its push is clamped away by the tendon.
  MuJoCo clamps a tendon's total before each actuator's own ``forcerange``, so the winch has none
  (one would cancel part of the damper's pull first). ``slewmax`` = ``targetVelocity`` moves u
  toward the command by at most targetVelocity·dt per step (MuJoCo's own rate limit, an
  activation state). At the limit the tension saturates (the motor's current limit) while u stays
  where it was commanded: unlike NTRT's actuator, the rest length is not paid out to L − maxTens / k.
- **dampers**: one ``damper`` actuator per tendon, force −``damping`` · dL/dt · ctrl, ctrl ∈ [0, 1].
  MuJoCo has no tension-only damper, so the stepping loop does what a user would: between
  ``mj_step1`` and ``mj_step2`` it sets ctrl = 1 where the cable is taut (L > u at the step's
  start; u moves by at most targetVelocity·dt = 1.5 mm within the step) and 0 where it is slack.
  Together with the tendon's clamp the damper adds to a taut cable's pull and may cancel it, never
  more; NTRT instead clips the damper to ±k (L − L0).
- **encoders**: the winch's state u (the pid's slew activation) is the rest length an encoder
  reports: as in the data format, a reading of L0_zero = node-to-node length of the nominal robot
  − pretension / k (0.878 m) means "as assembled", so reading = L0_zero + (u − u_build(θ)); while
  the tension is clamped at maxTens the reading keeps the setpoint (it does not see the slip).
- **delay**: ``Effects.actuator_delay`` is MuJoCo's actuator ``delay`` with a history of
  delay / dt commands, primed with the build rest lengths: a command reaches the winch that much later.
- **world**: a plane (tilted by ``Effects.slope``), friction 0.5, condim 3, MuJoCo's default soft
  contact, ``implicitfast`` at 1 ms, gravity −9.81 along world z. Effects MuJoCo has no element
  for (drag, hysteresis, ground viscosity) are refused; ``marker_offset`` is the recorder's.

Lengths in m, forces in N, times in s.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.effects import Effects
from testbed.params import CABLE_ENDS, NOMINAL, ROD_ENDS, cable_names, closed_faces, node_layout

__all__ = ["NativeMujocoRobot", "NativeDiverged", "NativeSnapshot", "mjcf", "encoder_zero", "UNSUPPORTED"]

_DT = 1e-3
_DROP = 0.02
_FRICTION = 0.5
_MAX_SPEED = 30.0
_PAYLOAD_RADIUS = 1e-3
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
_N = len(CABLE_ENDS)
#: effects with no MuJoCo element in this robot
UNSUPPORTED = ("drag", "hysteresis", "ground_viscosity")


class NativeDiverged(RuntimeError):
    """A node moved faster than 30 m/s or became NaN: the simulation blew up."""


@dataclass(frozen=True)
class NativeSnapshot:
    """MuJoCo's whole integration state (qpos, qvel, act, ctrl, command history, time, warm start)."""

    state: np.ndarray


def _rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
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


def _text(values) -> str:
    return " ".join(f"{float(x):.17g}" for x in np.ravel(values))


def _quat(rot: np.ndarray) -> str:
    """MuJoCo's quaternion text (w x y z) of a rotation matrix (3 x 3)."""
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rot, float).ravel())
    return _text(q)


def build_nodes(theta: dict[str, float], normal: np.ndarray, face: int = 0) -> np.ndarray:
    """Node positions (12 x 3) at build: closed face ``face`` toward the ground of normal ``normal``,
    the lowest node ``radius`` + 2 cm above it, centred over the world origin."""
    nodes = node_layout(theta["rod_length"], theta["rod_space"])
    outward = nodes[list(closed_faces()[face])].mean(axis=0)
    nodes = nodes @ _rotation(outward / np.linalg.norm(outward), -normal).T
    height = nodes @ normal
    return nodes + normal * (theta["radius"] + _DROP - height.min()) - np.r_[nodes[:, :2].mean(axis=0), 0.0]


def anchors(nodes: np.ndarray, radius: float) -> np.ndarray:
    """Cable anchors (24 x 2 x 3): each end on its node's rim, ``radius`` toward the other end,
    perpendicular to the rod."""
    out = np.empty((len(CABLE_ENDS), 2, 3))
    for j, ends in enumerate(CABLE_ENDS):
        for side, (me, other) in enumerate((ends, ends[::-1])):
            a, b = ROD_ENDS[me // 2]
            axis = (nodes[b] - nodes[a]) / np.linalg.norm(nodes[b] - nodes[a])
            d = nodes[other] - nodes[me]
            perp = d - (d @ axis) * axis
            out[j, side] = nodes[me] + radius * perp / np.linalg.norm(perp)
    return out


def encoder_zero() -> np.ndarray:
    """The reading (24,) [m] that means "as assembled": node-to-node cable length of the nominal
    robot minus pretension / k (0.878 m each)."""
    nodes = node_layout(NOMINAL["rod_length"], NOMINAL["rod_space"])
    length = np.linalg.norm(nodes[CABLE_ENDS[:, 1]] - nodes[CABLE_ENDS[:, 0]], axis=1)
    return length - NOMINAL["pretension"] / NOMINAL["stiffnessActive"]


def _rod(i: int, nodes: np.ndarray, ends: np.ndarray, theta: dict[str, float], effects: Effects) -> str:
    """MJCF of rod i: a free body at the rod's centre, z along node 2i -> 2i+1, its mass cylinders,
    contact capsules, payload and cable sites (``ends``: world anchors 24 x 2 x 3)."""
    a, b = nodes[2 * i], nodes[2 * i + 1]
    centre, rot = 0.5 * (a + b), _rotation(np.array([0.0, 0.0, 1.0]), (b - a) / np.linalg.norm(b - a))
    h, l_mp = 0.5 * theta["rod_length"], theta["rod_length_mp"]
    l_end = h - 0.5 * l_mp
    parts = ((theta["radius"], theta["density"], -h, -h + l_end),
             (theta["radius_mp"], theta["density_mp"], -h + l_end, h - l_end),
             (theta["radius"], theta["density"], h - l_end, h))
    geoms = "".join(f'<geom class="mass" size="{r:.17g}" density="{rho:.17g}" fromto="0 0 {z0:.17g} 0 0 {z1:.17g}"/>'
                    f'<geom class="contact" size="{r:.17g}" fromto="0 0 {z0:.17g} 0 0 {z1:.17g}"/>'
                    for r, rho, z0, z1 in parts)
    if effects.extra_mass > 0 and effects.extra_mass_rod == i:
        geoms += (f'<geom class="mass" type="sphere" size="{_PAYLOAD_RADIUS}" mass="{effects.extra_mass:.17g}" '
                  f'pos="0 0 {effects.extra_mass_at:.17g}"/>')
    sites = "".join(f'<site name="{name}_{"ab"[s]}" pos="{_text(rot.T @ (ends[j, s] - centre))}"/>'
                    for j, name in enumerate(cable_names()) for s in (0, 1) if CABLE_ENDS[j, s] // 2 == i)
    return f'<body name="rod{i}" pos="{_text(centre)}" quat="{_quat(rot)}"><freejoint/>{geoms}{sites}</body>'


def _winch(name: str, theta: dict[str, float], delay_steps: int) -> str:
    """The pid winch on cable ``name`` (module docstring); a delay of ``delay_steps`` steps of 1 ms."""
    delay = f' nsample="{delay_steps}" delay="{delay_steps * _DT:.17g}"' if delay_steps else ""
    return (f'<pid name="w{name[1:]}" tendon="{name}" input="pos" kp="{theta["stiffnessActive"]:.17g}" '
            f'slewmax="{theta["targetVelocity"]:.17g}"{delay}/>')


def _damper(name: str, theta: dict[str, float]) -> str:
    """The cable's damper on ``name``: force −damping · dL/dt · ctrl, ctrl 1 while taut, 0 while slack."""
    return f'<damper name="d{name[1:]}" tendon="{name}" kv="{theta["damping"]:.17g}" ctrlrange="0 1"/>'


def mjcf(theta: dict[str, float], effects: Effects | None = None, *, face: int = 0) -> tuple[str, np.ndarray]:
    """(MJCF text of the robot at ``theta`` with ``effects`` (None: none), build rest lengths (24,) [m] =
    anchor-to-anchor length at build − pretension / k)."""
    effects = Effects() if effects is None else effects
    bad = [name for name in UNSUPPORTED if getattr(effects, name)]
    if bad:
        raise ValueError(f"the mujoco-native robot has no model of {bad}; use engine 'bullet' or 'mujoco'.")
    normal = effects.ground_normal()
    nodes = build_nodes(theta, normal, face)
    ends = anchors(nodes, theta["radius"])
    rest = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1) - theta["pretension"] / theta["stiffnessActive"]
    if np.any(rest <= 0):
        raise ValueError("pretension / stiffnessActive exceeds the cable length: rest lengths would be <= 0.")
    delay_steps = int(round(effects.actuator_delay / _DT))
    ground = _rotation(np.array([0.0, 0.0, 1.0]), normal)
    tendons = "".join(f'<spatial name="{n}" actuatorfrcrange="{-theta["maxTens"]:.17g} 0"><site site="{n}_a"/>'
                      f'<site site="{n}_b"/></spatial>' for n in cable_names())
    xml = (f'<mujoco model="superball-native"><compiler autolimits="true"/>'
           f'<option timestep="{_DT}" integrator="implicitfast" gravity="0 0 -9.81"/>'
           f'<default><default class="mass"><geom type="cylinder" contype="0" conaffinity="0" group="3"/></default>'
           f'<default class="contact"><geom type="capsule" density="0" condim="3" '
           f'friction="{_FRICTION} 0.005 0.0001"/></default></default>'
           f'<worldbody><geom name="ground" type="plane" size="0 0 1" condim="3" friction="{_FRICTION} 0.005 0.0001" '
           f'quat="{_quat(ground)}"/>' + "".join(_rod(i, nodes, ends, theta, effects) for i in range(6))
           + f'</worldbody><tendon>{tendons}</tendon><actuator>'
           + "".join(_winch(n, theta, delay_steps) for n in cable_names())
           + "".join(_damper(n, theta) for n in cable_names()) + "</actuator></mujoco>")
    return xml, rest


def _rotations(quat: np.ndarray) -> np.ndarray:
    """Rotation matrices (n x 3 x 3) of unit quaternions (n x 4, w x y z)."""
    w, x, y, z = quat.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=1)


class NativeMujocoRobot:
    """The SUPERball at parameters ``theta`` (dict of the 15 names) with ``effects`` in MuJoCo's own
    tendons and pid winches. ``step(targets)`` advances 1 ms with 24 true target rest lengths [m]."""

    __test__ = False     # not a pytest class
    dt = _DT
    engine, engine_name = "mujoco-native", "MuJoCo (native tendons and winches)"

    def __init__(self, theta: dict[str, float], effects: Effects | None = None, *, face: int = 0) -> None:
        self.theta, self.effects = dict(theta), Effects() if effects is None else effects
        xml, rest = mjcf(self.theta, self.effects, face=face)
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        self.half = 0.5 * self.theta["rod_length"]
        self.encoder_offset = rest - encoder_zero()
        self._bodies = np.array([self.model.body(f"rod{i}").id for i in range(6)])
        self._qpos = self.model.jnt_qposadr[self.model.body_jntadr[self._bodies]][:, None] + np.arange(7)
        self._qvel = self.model.jnt_dofadr[self.model.body_jntadr[self._bodies]][:, None] + np.arange(6)
        self._act = self.model.actuator_actadr[:_N].copy()
        names = cable_names()
        self._site_local = np.array([[self.model.site(f"{n}_{s}").pos for s in "ab"] for n in names])
        self._site_rod = CABLE_ENDS // 2
        self.data.act[self._act] = rest
        self.data.ctrl[:_N] = rest
        self.data.ctrl[_N:] = 1.0
        for i in range(self.model.nu):
            if self.model.actuator_delay[i] > 0:
                mujoco.mj_initCtrlHistory(self.model, self.data, i, None,
                                          np.full(self.model.actuator_history[i, 0], rest[i]))
        mujoco.mj_forward(self.model, self.data)

    # ---------------------------------------------------------------- state
    @property
    def time(self) -> float:
        return float(self.data.time)

    @property
    def rest(self) -> np.ndarray:
        """True rest lengths (24,) [m]: the winches' effective setpoints (encoder reading + offset)."""
        return self.data.act[self._act].copy()

    def readings(self) -> np.ndarray:
        """Encoder readings (24,) [m] in the data format's convention (L0_zero means as assembled)."""
        return self.rest - self.encoder_offset

    def _frames(self) -> tuple[np.ndarray, np.ndarray]:
        """(rod centres 6 x 3, rotations 6 x 3 x 3) of the present state, read from qpos."""
        q = self.data.qpos[self._qpos]
        quat = q[:, 3:] / np.linalg.norm(q[:, 3:], axis=1, keepdims=True)
        return q[:, :3].copy(), _rotations(quat)

    def nodes(self) -> np.ndarray:
        """Rod endpoints (12 x 3) [m]: rod centre ∓ half a rod along its axis (nodes 2i, 2i+1)."""
        centre, rot = self._frames()
        axis = rot[:, :, 2]
        return np.stack([centre - self.half * axis, centre + self.half * axis], axis=1).reshape(12, 3)

    def node_velocities(self) -> np.ndarray:
        """Velocities (12 x 3) [m/s] of the rod endpoints: v_centre + ω × (node − centre), where a
        free joint's qvel is the body origin's world velocity and the body-frame angular velocity."""
        centre, rot = self._frames()
        qvel = self.data.qvel[self._qvel]
        w = np.einsum("iab,ib->ia", rot, qvel[:, 3:])
        arm = (self.nodes().reshape(6, 2, 3) - centre[:, None])
        return (qvel[:, None, :3] + np.cross(w[:, None], arm)).reshape(12, 3)

    def cable_lengths(self) -> np.ndarray:
        """Anchor-to-anchor lengths (24,) [m] of the present state (the tendons' lengths)."""
        centre, rot = self._frames()
        r = self._site_rod
        ends = np.einsum("jsab,jsb->jsa", rot[r], self._site_local) + centre[r]
        return np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)

    def tensions(self) -> np.ndarray:
        """Cable tensions (24,) [N] MuJoCo applied in the last step: −(winch + damper force) on each
        tendon, after the tendon's clamp to [0, maxTens]."""
        force = self.data.actuator_force
        return -(force[:_N] + force[_N:]) + 0.0          # + 0.0: no −0.0 for a slack cable

    def com(self) -> np.ndarray:
        """Centre of mass of the robot (3,) [m]."""
        centre, rot = self._frames()
        ipos = centre + np.einsum("iab,ib->ia", rot, self.model.body_ipos[self._bodies])
        mass = self.model.body_mass[self._bodies]
        return mass @ ipos / mass.sum()

    def check(self) -> None:
        """Raise :class:`NativeDiverged` if a node is NaN or faster than 30 m/s."""
        v = self.node_velocities()
        if not np.all(np.isfinite(v)) or np.abs(v).max() > _MAX_SPEED:
            raise NativeDiverged(f"mujoco-native diverged at t = {self.time:.3f} s "
                                 f"(node speed {np.abs(v).max():.3g} m/s).")

    # ---------------------------------------------------------------- dynamics
    def step(self, targets: np.ndarray) -> None:
        """One 1 ms step: the 24 true target rest lengths [m] go to the winches' controls (MuJoCo
        delays, rate-limits and applies them); between mj_step1 (positions, velocities, tendon
        lengths) and mj_step2 each damper is switched on where its cable is taut (L > u)."""
        self.data.ctrl[:_N] = targets
        mujoco.mj_step1(self.model, self.data)
        self.data.ctrl[_N:] = self.data.ten_length > self.data.act[self._act]
        mujoco.mj_step2(self.model, self.data)

    def snapshot(self) -> NativeSnapshot:
        """Everything needed to come back to this instant (for the controller's trials)."""
        state = np.empty(mujoco.mj_stateSize(self.model, _STATE))
        mujoco.mj_getState(self.model, self.data, state, _STATE)
        return NativeSnapshot(state)

    def restore(self, snap: NativeSnapshot) -> None:
        mujoco.mj_setState(self.model, self.data, snap.state, _STATE)
        mujoco.mj_forward(self.model, self.data)

    def forget(self, snap: NativeSnapshot) -> None:
        """Nothing to free: a snapshot is an array."""

    def close(self) -> None:
        """Nothing to release: the model and data are freed with the object."""
