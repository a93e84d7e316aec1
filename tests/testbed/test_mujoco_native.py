"""The SUPERball in MuJoCo's own tendons and pid winches (benchmarks/testbed/mujoco_native.py): it shares
no robot code, its cables never push, its winches are rate-limited and delayed by MuJoCo, and its
files fulfil the data format."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from testbed.datasets import Robot, build_robot, make_dataset
from testbed.effects import Effects
from testbed.mujoco_native import NativeMujocoRobot
from testbed.params import NOMINAL, closed_faces

FORBIDDEN = ("testbed.cable_robot", "testbed.robot", "testbed.mujoco_robot", "testbed.controller", "testbed.record",
             "testbed.datasets", "pybullet")
LIBRARY = ("physics", "belief", "criticism", "embeddings", "planners", "tensegrid")


def _settled(effects: Effects | None = None, seconds: float = 2.0) -> NativeMujocoRobot:
    robot = NativeMujocoRobot(dict(NOMINAL), effects)
    for _ in range(int(round(seconds / robot.dt))):
        robot.step(robot.rest)
    return robot


def test_it_imports_no_robot_code_and_nothing_from_the_library():
    code = ("import sys, testbed.mujoco_native; "
            f"print([m for m in sys.modules if m in {FORBIDDEN!r} or m.split('.')[0] in {LIBRARY!r}])")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_the_rods_weigh_what_the_hardware_description_says():
    """Mass, centre of mass and inertia of each rod (with a payload on rod 2) from MuJoCo's cylinder
    geoms equal the three-cylinder formulas the other engines use."""
    from testbed.cable_robot import rod_inertia
    effects = Effects(extra_mass=0.5, extra_mass_rod=2, extra_mass_at=0.4)
    robot = NativeMujocoRobot(dict(NOMINAL), effects)
    for i, body in enumerate(robot._bodies):
        mass, zc, transverse, axial = rod_inertia(NOMINAL, effects, i)
        assert robot.model.body_mass[body] == pytest.approx(mass, rel=1e-12)
        np.testing.assert_allclose(robot.model.body_ipos[body], [0, 0, zc], atol=1e-12)
        np.testing.assert_allclose(np.sort(robot.model.body_inertia[body]), np.sort([transverse, transverse, axial]),
                                   atol=1e-6)


def test_settles_on_a_face_with_its_nodes_a_cap_radius_above_the_floor():
    robot = _settled()
    nodes, tension = robot.nodes(), robot.tensions()
    low = np.argsort(nodes[:, 2])[:3]
    assert tuple(sorted(int(i) for i in low)) in closed_faces()
    assert np.all(np.abs(nodes[low, 2] - NOMINAL["radius"]) < 1e-3), nodes[low, 2]
    assert np.abs(robot.node_velocities()).max() < 1e-3
    assert 100 < tension.mean() < 200                       # the pretension (150 N) holds the robot
    np.testing.assert_allclose(robot.readings(), 0.878, atol=1e-3)   # encoders read "as assembled"


def test_cables_never_push_nor_pull_while_slack():
    """Half the cables shortened hard, half lengthened fast: every tension stays in [0, maxTens],
    the limit is reached, and a slack cable (shorter than its rest length by more than one step of
    winch travel) gives nothing, even while it lengthens (its damper is off)."""
    robot = _settled(seconds=0.5)
    start = robot.rest.copy()
    command = start * np.where(np.arange(24) % 2, 0.6, 1.4)
    peak, lowest, slack_pull, slack_lengthening = 0.0, np.inf, 0.0, 0
    for _ in range(600):
        length, rest = robot.cable_lengths(), robot.rest
        robot.step(command)
        tension = robot.tensions()
        slack = length < rest - NOMINAL["targetVelocity"] * robot.dt
        slack_lengthening += int(np.sum(slack & (robot.cable_lengths() > length)))
        peak, lowest = max(peak, tension.max()), min(lowest, tension.min())
        slack_pull = max(slack_pull, tension[slack].max(initial=0.0))
        robot.check()
    assert lowest >= 0.0
    assert peak == pytest.approx(NOMINAL["maxTens"], rel=1e-9)
    assert slack_lengthening > 100 and slack_pull == 0.0


@pytest.mark.parametrize("delay", [0.0, 0.05])
def test_a_reading_moves_toward_its_command_at_most_at_target_velocity_and_late_by_the_delay(delay):
    robot = _settled(Effects(actuator_delay=delay), seconds=0.3)
    start = robot.readings()
    command = robot.rest.copy()
    command[5] *= 0.9                                       # 88 mm shorter
    readings = []
    for _ in range(150):
        robot.step(command)
        readings.append(robot.readings())
    readings = np.array(readings)
    moved = readings - start
    first = int(np.argmax(np.abs(moved[:, 5]) > 0))
    assert first == round(delay / robot.dt)                 # the first step, or 50 steps (50 ms) later
    assert np.all(np.abs(moved[:, np.arange(24) != 5]) == 0)
    speed = np.abs(np.diff(np.vstack([start, readings])[:, 5])) / robot.dt
    assert speed.max() == pytest.approx(NOMINAL["targetVelocity"], rel=1e-9)
    assert np.all(np.diff(readings[:, 5]) <= 0)             # toward the command, never past it
    assert readings[-1, 5] >= start[5] - 0.088 - 1e-12


def test_snapshots_replay_exactly():
    robot = _settled(Effects(actuator_delay=0.05), seconds=0.2)
    snap = robot.snapshot()
    command = robot.rest * 0.8
    for _ in range(80):
        robot.step(command)
    first = robot.nodes(), robot.rest
    robot.restore(snap)
    for _ in range(80):
        robot.step(command)
    np.testing.assert_array_equal(robot.nodes(), first[0])
    np.testing.assert_array_equal(robot.rest, first[1])


def test_effects_it_has_no_model_of_are_refused():
    for effects in (Effects(drag=3.0), Effects(hysteresis=0.3), Effects(ground_viscosity=20.0)):
        with pytest.raises(ValueError, match="mujoco-native"):
            build_robot(Robot(dict(NOMINAL), effects), "mujoco-native")


def test_a_nominal_data_set_fulfils_the_data_format(tmp_path):
    from physics.checks import check_file
    from physics.trajectory import load_trajectory
    paths = make_dataset("nominal", 0, tmp_path, engine="mujoco-native")
    assert [p.stem for p in paths] == ["flop_0", "flop_1", "flop_2", "heldout_0"]
    for path in paths:
        ds = load_trajectory(path)
        assert not check_file(path).errors, (path.name, check_file(path).lines())
        assert ds.attrs["length_reference"] == "encoder"
        assert "native tendons and winches" in ds.attrs["source"]
        np.testing.assert_allclose(ds["rest_length"].values[0], 0.878, atol=1e-3)
        np.testing.assert_allclose(ds["controls"].values[0], ds["rest_length"].values[0], atol=1e-12)
        com = ds["nodes"].values.mean(axis=1)
        assert np.linalg.norm(com[-1, :2] - com[0, :2]) >= 0.3, path.name
        step = np.abs(np.diff(ds["rest_length"].values, axis=0)).max()
        assert step <= NOMINAL["targetVelocity"] * 0.01 + 1e-12          # 10 ms between samples
    truth = json.loads((tmp_path / "truth.json").read_text())
    assert truth["engine"] == "mujoco-native" and truth["effects"] == {}
