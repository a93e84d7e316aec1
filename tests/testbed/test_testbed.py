"""The foreign testbed (benchmarks/testbed): its physical laws in both engines (Bullet and MuJoCo), its
independence, its files."""
from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from physics import load_trajectory
from testbed.cable_robot import CableRobot
from testbed.controller import Flop
from testbed.datasets import DATASETS, STREAMS, Robot, build_robot, flops_for, make_dataset, robot_for
from testbed.effects import Effects
from testbed.params import NOMINAL, closed_faces
from testbed.record import record_flop

TESTBED = Path(__file__).resolve().parents[2] / "benchmarks" / "testbed"
LIBRARY = {"physics", "belief", "embeddings", "planners", "criticism", "tensegrid"}
ENGINES = ["bullet", "mujoco"]


def _settled(effects: Effects = Effects(), seconds: float = 3.0, engine: str = "bullet") -> CableRobot:
    robot = build_robot(Robot(dict(NOMINAL), effects), engine)
    for _ in range(int(seconds / robot.dt)):
        robot.step(robot.rest)
    return robot


@pytest.fixture(scope="module", params=ENGINES)
def nominal_files(request, tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp(f"nominal-{request.param}")
    return {p.stem: p for p in make_dataset("nominal", 0, out, engine=request.param)}


def test_testbed_imports_nothing_from_the_library():
    files = sorted(TESTBED.glob("*.py"))
    assert len(files) >= 5
    for path in files:
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
                [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            for name in names:
                assert name.split(".")[0] not in LIBRARY, f"{path.name} imports {name}"


@settings(max_examples=60, deadline=None)
@given(stretch=st.floats(-0.2, 0.2), rate=st.floats(-5.0, 5.0), hysteresis=st.floats(0.0, 0.9))
def test_cables_never_push(stretch, rate, hysteresis):
    robot = CableRobot.__new__(CableRobot)                # the force law alone, no world
    robot.k, robot.c, robot.dt = 800.0, 200.0, 1e-3
    robot.effects = Effects(hysteresis=hysteresis)
    robot.rest = np.full(24, 0.8)
    length = robot.rest + stretch
    robot.last_length = length - rate * robot.dt
    force = robot.cable_forces(length)
    assert np.all(force >= 0)
    if stretch <= 0:
        assert np.all(force == 0)                         # a slack cable gives nothing, even shortening fast
    assert np.all(force <= 2 * robot.k * max(stretch, 0) + 1e-9)


@pytest.mark.parametrize("engine", ENGINES)
def test_slack_cable_exerts_no_force_in_the_world(engine):
    robot = _settled(seconds=0.5, engine=engine)
    rest = robot.rest.copy()
    rest[0] = 2.0                                        # far longer than the cable: slack
    robot.rest = rest
    robot.step(rest)
    assert robot.tensions()[0] == 0.0
    robot.close()


@pytest.mark.parametrize("engine", ENGINES)
def test_settles_on_a_face_and_stays_there(engine):
    robot = _settled(engine=engine)
    before = robot.nodes()
    base = tuple(sorted(int(i) for i in np.argsort(before[:, 2])[:3]))
    for _ in range(2000):
        robot.step(robot.rest)
    after, tension = robot.nodes(), robot.tensions()
    robot.close()
    assert base in closed_faces()
    assert tuple(sorted(int(i) for i in np.argsort(after[:, 2])[:3])) == base
    assert np.abs(after - before).max() < 0.01
    assert 100 < tension.mean() < 200


def test_flops_move_the_centre_of_mass_and_pass_the_loader(nominal_files):
    assert set(nominal_files) == {"flop_0", "flop_1", "flop_2", "heldout_0"}
    for path in nominal_files.values():
        ds = load_trajectory(path)
        com = ds["nodes"].values.mean(axis=1)
        assert np.linalg.norm(com[-1, :2] - com[0, :2]) >= 0.3, path.name
        assert ds.attrs["length_reference"] == "encoder"
        assert json.loads(ds.attrs["testbed_theta"])["rod_length"] == NOMINAL["rod_length"]
    truth = json.loads((next(iter(nominal_files.values())).parent / "truth.json").read_text())
    assert truth["effects"] == {}
    engine = {"bullet": "Bullet", "mujoco": "MuJoCo"}[truth["engine"]]
    assert f"SUPERball in {engine}" in load_trajectory(nominal_files["flop_0"]).attrs["source"]


def _short_run(name: str, seed: int, engine: str = "bullet") -> np.ndarray:
    """Observed nodes of 0.3 s of the data set's first flop (short planning trials, noise on)."""
    from testbed.record import Observation, to_dataset
    spec, rng = robot_for(name, seed)
    robot = build_robot(spec, engine)
    for _ in range(300):
        robot.step(robot.rest)
    flop = flops_for(rng)["flop_0"]
    rec = record_flop(robot, Flop(heading=flop.heading, trial=0.03), duration=0.3)
    ds = to_dataset(rec, robot, Observation(noise=1e-3), np.random.default_rng(seed), attrs={})
    robot.close()
    return ds["nodes"].values


@pytest.mark.parametrize("engine", ENGINES)
def test_same_seed_same_data_other_seed_other_data(engine):
    first, again = _short_run("perturbed", 3, engine), _short_run("perturbed", 3, engine)
    other = _short_run("perturbed", 4, engine)
    assert np.array_equal(first, again)
    assert not np.allclose(first, other, atol=1e-3)


@pytest.mark.parametrize("engine", ENGINES)
def test_slope_tilts_the_ground_in_the_world_frame(engine):
    effects = Effects(slope=np.deg2rad(5.0), slope_azimuth=0.7)
    robot = _settled(effects, engine=engine)
    nodes = robot.nodes()
    base = nodes[np.argsort(nodes @ effects.ground_normal())[:3]]
    normal = np.cross(base[1] - base[0], base[2] - base[0])
    normal *= np.sign(normal[2]) / np.linalg.norm(normal)
    robot.close()
    assert np.degrees(np.arccos(normal @ effects.ground_normal())) < 1.0
    assert np.degrees(np.arccos(normal[2])) > 4.0            # the resting face is tilted, not level


def test_marker_offset_and_missing_samples_reach_only_the_observation():
    from testbed.record import Observation, to_dataset
    robot = _settled(Effects(marker_offset=(0.02, -0.015, 0.01)), seconds=0.5)
    rec = record_flop(robot, Flop(), duration=0.2)
    ds = to_dataset(rec, robot, Observation(noise=0.0, missing=0.3), np.random.default_rng(0), attrs={})
    robot.close()
    nodes = ds["nodes"].values
    lost = np.isnan(nodes).any(axis=(1, 2))
    assert 0 < lost.sum() < len(lost)
    np.testing.assert_allclose(nodes[~lost] - rec.nodes[~lost], np.broadcast_to([0.02, -0.015, 0.01], nodes[~lost].shape))


@pytest.mark.parametrize("engine", ENGINES)
def test_actuator_delay_holds_the_rest_lengths_back(engine):
    moved = {}
    for delay in (0.0, 0.05):
        robot = _settled(Effects(actuator_delay=delay), 0.3, engine)
        start = robot.rest.copy()
        for _ in range(40):                                  # 40 ms of a command to shorten by 10 %
            robot.step(start * 0.9)
        moved[delay] = float((start - robot.rest).mean())
        robot.close()
    assert moved[0.05] == 0.0                                # the command has not arrived yet
    assert moved[0.0] > 0.03                                 # 40 ms at 1.5 m/s, clamped by maxTens


def test_extra_mass_adds_its_mass():
    from testbed.robot import rod_inertia
    plain = rod_inertia(NOMINAL, Effects(), 2)
    heavy = rod_inertia(NOMINAL, Effects(extra_mass=0.5, extra_mass_rod=2, extra_mass_at=0.4), 2)
    assert heavy[0] == pytest.approx(plain[0] + 0.5)
    assert heavy[1] == pytest.approx(0.5 * 0.4 / heavy[0])
    assert plain[0] == pytest.approx(3.0, rel=0.05)          # SUPERball: about 3 kg per rod


@pytest.mark.parametrize("engine", ENGINES)
def test_actuators_keep_tension_under_max_tens(engine):
    robot = _settled(seconds=0.3, engine=engine)
    command = robot.rest * 0.5                               # far shorter than any cable can be pulled
    peak = 0.0
    for _ in range(500):
        robot.step(command)
        peak = max(peak, robot.tensions().max())
    robot.close()
    assert peak <= NOMINAL["maxTens"] * 1.02               # one step of travel past the clamp at most
    assert peak > 0.8 * NOMINAL["maxTens"]                   # and the command did pull hard


@pytest.mark.parametrize("seed", [0, 1])
def test_the_ground_plane_of_testbed_flops_on_a_3_degree_slope_and_on_flat_ground(seed: int) -> None:
    """physics.ground on the foreign robot's files: on the 3° slope the plane's normal is within 0.3°
    of the testbed's floor normal and its height within 3 mm of where the testbed's own nodes rest
    above a floor through the origin (read off the settled robot); flat ground is level within 0.3°."""
    from physics.ground import ground_plane
    from testbed.datasets import cached_dataset

    robot = _settled(seconds=2.0)
    resting = float(np.sort(robot.nodes()[:, 2])[:3].mean())     # the contact nodes' height above the floor
    robot.close()
    truth = json.loads(Path(cached_dataset("slope", seed, noise=0.0002)["flop_0"]).with_name("truth.json").read_text())
    normal = Effects(slope=truth["effects"]["slope"], slope_azimuth=truth["effects"]["slope_azimuth"]).ground_normal()
    for name in ("slope", "nominal"):
        for label, path in cached_dataset(name, seed, noise=0.0002).items():
            plane = ground_plane(load_trajectory(path))
            assert plane is not None, (name, label)
            if name == "slope":
                assert np.degrees(np.arccos(np.clip(plane.normal @ normal, -1, 1))) < 0.3, (label, plane)
                assert abs(plane.height - resting) < 0.003, (label, plane.height, resting)
            else:
                assert plane.tilt_deg < 0.3, (label, plane)


def test_flops_of_version_2_are_drawn_per_seed_and_version_1_stays_fixed():
    """Version 1 keeps its fixed actuation (every recorded figure was measured on it); version 2
    draws each flop's actuation from the seed, so seeds of one robot no longer replay the same flops."""
    fixed = flops_for(robot_for("nominal", 0)[1], 1)
    assert {(f.change, f.n_cables, f.start, f.stop) for k, f in fixed.items() if k != "heldout_0"} == {(0.3, 4, 0.2, 1.2)}
    assert (fixed["heldout_0"].change, fixed["heldout_0"].n_cables) == (0.25, 5)
    drawn = [(f.change, f.n_cables, f.start, f.stop) for seed in range(10)
             for f in flops_for(robot_for("nominal", seed)[1], 2).values()]
    assert len(set(drawn)) == len(drawn) == 40
    assert flops_for(robot_for("nominal", 3)[1], 2) == flops_for(robot_for("nominal", 3)[1], 2)
    with pytest.raises(ValueError, match="version"):
        flops_for(robot_for("nominal", 0)[1], 3)


def test_contact_effects_bound_on_the_foreign_robot_cannot_sink_it() -> None:
    """SensorBias and EndCapRadius bound to the testbed's resting robot (flat cylinder ends rest
    their nodes lower than DART's spheres at the same radius) measure that height against the
    nominal radius, and their boxes hold neither the +36 mm bias nor the +30 mm cap that free fits
    of the dynamics chose on its viscous floor (docs/diagnose.md); the marker offset's 10 mm along
    z shows in the measured bias."""
    from physics.effects import EndCapRadius, SensorBias
    from physics.effects.world import contact_excess
    from testbed.datasets import cached_dataset

    robot = _settled(seconds=2.0)
    resting = float(np.sort(robot.nodes()[:, 2])[:3].mean())
    robot.close()
    flops = {name: [load_trajectory(cached_dataset(name, 0, noise=0.0002, version=2)[f"flop_{k}"]) for k in (0, 1)]
             for name in ("ground_viscosity", "marker_offset")}
    excess = contact_excess(flops["ground_viscosity"])
    assert excess == pytest.approx(resting - NOMINAL["radius"], abs=0.002) and excess < -0.005
    for effect in (SensorBias(), EndCapRadius()):
        (p,) = effect.bind(flops["ground_viscosity"]).parameters()
        assert p.lower <= excess <= p.upper and p.upper < 0.025, (effect.name, p)
    assert contact_excess(flops["marker_offset"]) - excess == pytest.approx(0.01, abs=0.002)


def test_the_mujoco_robot_rests_its_nodes_a_cap_radius_above_the_floor_and_matches_bullet_at_rest():
    """MuJoCo's capsules centre a hemisphere on each node, so the resting robot's three lowest nodes
    sit ``radius`` above a level floor (less MuJoCo's soft-contact penetration, under 1 mm); Bullet's
    flat ends rest them lower. The robot is the same: both hold the same pretension at rest."""
    mujoco, bullet = _settled(seconds=2.0, engine="mujoco"), _settled(seconds=2.0, engine="bullet")
    low = {name: np.sort(r.nodes()[:, 2])[:3] for name, r in (("mujoco", mujoco), ("bullet", bullet))}
    tension = {name: r.tensions().mean() for name, r in (("mujoco", mujoco), ("bullet", bullet))}
    mujoco.close()
    bullet.close()
    assert np.all(np.abs(low["mujoco"] - NOMINAL["radius"]) < 1e-3), low
    assert np.all(low["bullet"] < NOMINAL["radius"] - 5e-3), low
    assert tension["mujoco"] == pytest.approx(tension["bullet"], rel=0.05)
    with pytest.raises(ValueError, match="engine"):
        build_robot(Robot(dict(NOMINAL), Effects()), "ode")


def test_the_command_line_passes_the_engine_and_folders_keep_engines_apart(monkeypatch, tmp_path):
    import testbed.__main__ as cli
    calls = []
    monkeypatch.setattr(cli, "make_dataset", lambda name, seed, out, **kw: calls.append((name, seed, out, kw)) or [])
    assert cli.main(["dataset", "nominal", "--engine", "mujoco", "--seed", "2"]) == 0
    name, seed, out, kw = calls[0]
    assert (name, seed, kw["engine"]) == ("nominal", 2, "mujoco")
    assert out != cli.default_folder("nominal", 2) and out == cli.default_folder("nominal", 2, "mujoco")
    with pytest.raises(SystemExit):
        cli.main(["dataset", "nominal", "--engine", "ode"])


#: the data sets the saved rows were drawn from before streams were fixed, in their streams' order
#: (then their sorted position among themselves)
DRAWN_BEFORE_STREAMS = ("actuator_delay", "drag", "extra_mass", "ground_viscosity", "hysteresis", "marker_offset",
                        "nominal", "perturbed", "slope", "slope+delay")


def test_each_data_set_draws_from_its_own_stream_and_a_new_one_moves_none():
    assert sorted(STREAMS) == sorted(DATASETS)
    assert len(set(STREAMS.values())) == len(STREAMS)
    assert [STREAMS[n] for n in DRAWN_BEFORE_STREAMS] == list(range(len(DRAWN_BEFORE_STREAMS)))
    azimuth = np.random.default_rng([3, STREAMS["slope"]]).uniform(0, 2 * np.pi)
    assert robot_for("slope", 3)[0].effects.slope_azimuth == azimuth
    both = robot_for("drag+hysteresis", 0)[0].effects
    assert (both.drag, both.hysteresis) == (3.0, 0.3)
