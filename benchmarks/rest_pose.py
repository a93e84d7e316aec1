"""Does DART hold the foreign robot's resting pose? The cables' pull on the rods off the ground,
and how far DART moves from that pose with no command.

For nominal testbed robot ``--seed`` settled for 3 s (benchmarks/testbed, its ground's rolling
friction as made, or 0 with ``--ground-rolling 0``), this script prints the height of its lowest
nodes and

- for each rod off the ground, the vertical net force [N] of its cables at the resting pose: the
  testbed's (anchors fixed to its rods, where settling left them), DART's re-aimed anchors
  (physics.effects.CableAnchors: each anchor aimed at its cable's other end) and DART's fixed
  anchors (physics.effects.FixedCableAnchors: body-frame anchors, each rod turned to aim them),
  all at the testbed's 6 cm offset and tension law T = k max(0, L_anchor − L0_anchor); at rest it
  must carry the rod's weight m g;
- the mean node distance [mm] of DART from the resting pose at 0.1, 0.2, 0.5 and 1 s, placed there
  at rest and holding its build rest lengths, for re-aimed or fixed anchors, spheres or cylinder
  caps (physics.effects.CylinderCaps), and the last with physics.effects.RollingResistance at
  ``--lever`` μ_r, all at the testbed's true θ with its actuator law.

    .venv/bin/python benchmarks/rest_pose.py --seed 2
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
from scipy.spatial.transform import Rotation

from physics import T6Model
from physics.effects import (
    CableAnchors,
    CylinderCaps,
    Effect,
    FixedCableAnchors,
    RollingResistance,
    TensionLimitedActuation,
    model_space,
)
from physics.effects.anchors import anchor_points, rest_shift
from physics.effects.fixed_anchors import body_anchors, orient_rods
from physics.geometry import CABLE_NODES, rod_poses_from_nodes
from physics.tensegrity import build_rest_lengths

OFFSET = 0.06
TIMES = (0.1, 0.2, 0.5, 1.0)


def settled_testbed(seed: int, ground_rolling: float) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray]:
    """(θ, nodes (12 x 3) [m], cable anchors (24 x 2 x 3) [m], cable forces (24,) [N]) of the testbed
    robot at rest after 3 s."""
    from testbed.datasets import SETTLE_S, robot_for
    from testbed.robot import TestbedRobot
    robot_def, _ = robot_for("nominal", seed)
    robot = TestbedRobot(robot_def.theta, robot_def.effects, ground_rolling=ground_rolling)
    try:
        for _ in range(int(round(SETTLE_S / robot.dt))):
            robot.step(robot.rest)
        poses = robot._poses()
        length, _, anchors = robot._cable_geometry(poses)
        return dict(robot.theta), robot.nodes(poses), anchors, robot.cable_forces(length)
    finally:
        robot.close()


def net_vertical(anchors: np.ndarray, tension: np.ndarray) -> np.ndarray:
    """Vertical net cable force (6,) [N] on each rod: Σ ±T_j ê_j·z over the cables it anchors."""
    d = anchors[:, 1] - anchors[:, 0]
    force = tension[:, None] * d / np.linalg.norm(d, axis=1, keepdims=True)
    net = np.zeros((6, 3))
    np.add.at(net, CABLE_NODES[:, 0] // 2, force)
    np.add.at(net, CABLE_NODES[:, 1] // 2, -force)
    return net[:, 2]


def dart_anchors(theta: dict, nodes: np.ndarray, fixed: bool) -> np.ndarray:
    """DART's anchors (24 x 2 x 3) [m] at ``nodes``: re-aimed, or fixed to rods turned to aim them."""
    if not fixed:
        return anchor_points(nodes, OFFSET)
    local = body_anchors(theta["rod_length"], theta["rod_space"], OFFSET)
    q = orient_rods(rod_poses_from_nodes(nodes)[0], local, OFFSET, 0.5 * theta["rod_length"]).reshape(6, 6)
    rot = Rotation.from_rotvec(q[:, :3]).as_matrix()
    out = np.empty_like(local)
    for side in (0, 1):
        rods = CABLE_NODES[:, side] // 2
        out[:, side] = q[rods, 3:] + np.einsum("jab,jb->ja", rot[rods], local[:, side])
    return out


def dart_tensions(theta: dict, anchors: np.ndarray) -> np.ndarray:
    """T = k max(0, L_anchor − (L0_build + δ)) (24,) [N] of cables assembled anchor to anchor."""
    rest = build_rest_lengths(theta) + rest_shift(theta["rod_length"], theta["rod_space"], OFFSET)
    length = np.linalg.norm(anchors[:, 1] - anchors[:, 0], axis=1)
    return theta["stiffnessActive"] * np.maximum(0.0, length - rest)


def held_still(theta: dict, nodes: np.ndarray, anchors: Effect, caps: bool, lever: float = 0.0) -> str:
    """Mean node distance [mm] of DART from ``nodes`` at TIMES, placed there at rest."""
    effects = [TensionLimitedActuation(), anchors, *([CylinderCaps()] if caps else []),
               *([RollingResistance()] if lever > 0 else [])]
    space = model_space(effects)
    values = {**theta, anchors.parameters()[0].name: OFFSET, **({"rolling_resistance": lever} if lever > 0 else {})}
    model = T6Model(space.as_array({**space.as_dict(None), **values}, check_bounds=False), effects=effects)
    model.set_nodes(nodes)
    out = []
    for t in TIMES:
        model.step(None, n=int(round((t - model.time) / model.options.dt)))
        out.append(f"{1e3 * np.linalg.norm(model.node_positions() - nodes, axis=1).mean():6.1f}")
    return "  ".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--ground-rolling", type=float, default=1.0, help="the testbed ground's rolling friction")
    ap.add_argument("--lever", type=float, default=0.5, help="μ_r [m] of DART's rolling resistance (last row)")
    args = ap.parse_args(argv)
    theta, nodes, anchors, tension = settled_testbed(args.seed, args.ground_rolling)
    from testbed.effects import Effects
    from testbed.robot import rod_inertia
    weight = rod_inertia(theta, Effects(), 0)[0] * 9.81
    off_ground = [i for i in range(6) if nodes[2 * i:2 * i + 2, 2].min() > 2 * theta["radius"]]
    print(f"nominal testbed robot {args.seed}, ground rolling friction {args.ground_rolling:g}; rod weight "
          f"{weight:.2f} N; lowest nodes {', '.join(f'{1e3 * z:.1f}' for z in np.sort(nodes[:, 2])[:3])} mm above "
          f"the floor (cap radius {1e3 * theta['radius']:.0f} mm)")
    rows = {"testbed": net_vertical(anchors, tension)}
    for name, fixed in (("DART re-aimed anchors", False), ("DART fixed anchors", True)):
        at = dart_anchors(theta, nodes, fixed)
        rows[name] = net_vertical(at, dart_tensions(theta, at))
    for name, net in rows.items():
        print(f"{name:24s} vertical cable force on rods {off_ground} [N]: "
              + "  ".join(f"{net[i]:6.2f}" for i in off_ground))
    print(f"DART placed at the resting pose, mean node distance [mm] at {', '.join(f'{t:g}' for t in TIMES)} s:")
    for name, anchors_law, caps in (("re-aimed anchors, spheres", CableAnchors(), False),
                                    ("fixed anchors, spheres", FixedCableAnchors(), False),
                                    ("re-aimed anchors, cylinders", CableAnchors(), True),
                                    ("fixed anchors, cylinders", FixedCableAnchors(), True)):
        print(f"  {name:36s} {held_still(theta, nodes, anchors_law, caps)}", flush=True)
    name = f"fixed, cylinders, rolling {args.lever:g} m"
    print(f"  {name:36s} {held_still(theta, nodes, FixedCableAnchors(), True, args.lever)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
