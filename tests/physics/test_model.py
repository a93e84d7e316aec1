"""The T6 model by its laws: shape held without gravity, rest on a face, energy conservation,
determinism, and every parameter acting on the motion."""
from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from physics import (
    CABLE_NODES, ControllerError, FlopController, ReplayController, HoldController, ModelOptions, MotorGains, ParameterError, ParameterSpace,
    PhysicsError, T6Model, settled_model, simulate,
)


def _pair_distances(nodes):
    return np.linalg.norm(nodes[:, None] - nodes[None], axis=2)


def test_pretension_holds_the_shape_without_gravity():
    """At rod_space = rod_length / 4 the symmetric T6 with equal cables is a prestressed
    equilibrium: it keeps its shape exactly, and after a random kick it moves as a rigid body
    (shape within 1 mm) while every cable stays taut."""
    space = ParameterSpace.t6()
    options = ModelOptions(gravity=0.0, ground=False)
    model = T6Model(space.replace(rod_space=space["rod_length"].nominal / 4), options=options)
    start = _pair_distances(model.node_positions())
    model.settle(2.0)
    assert np.abs(_pair_distances(model.node_positions()) - start).max() < 1e-9
    model._set_velocities(np.random.default_rng(0).normal(0.0, 0.1, 36))
    for _ in range(6):
        model.settle(0.5)
        assert np.abs(_pair_distances(model.node_positions()) - start).max() < 1e-3
        assert np.all(model.tensions() > 100.0)


def test_nominal_geometry_is_not_an_equilibrium_but_stays_prestressed():
    """NTRT's rod_space = 0.45 m is 3.4 % off the equilibrium rod_length / 4: without gravity the
    robot swings along its soft (mechanism) mode, which cable damping cannot reach because the
    cable lengths stay equal along it. The cables never go slack."""
    model = T6Model(options=ModelOptions(gravity=0.0, ground=False))
    start = _pair_distances(model.node_positions())
    swing = 0.0
    for _ in range(8):
        model.settle(0.25)
        swing = max(swing, np.abs(_pair_distances(model.node_positions()) - start).max())
        assert np.all(model.tensions() > 100.0)
    assert 0.01 < swing < 0.1


def test_settles_on_a_face_and_stays():
    model = T6Model()
    model.settle(2.0)
    z = np.sort(model.node_positions()[:, 2])
    radius = model.params["radius"]
    np.testing.assert_allclose(z[:3], radius, atol=2e-3)          # three caps on the ground
    assert z[3] > radius + 0.2                                     # the rest well above it
    lowest = set(np.argsort(model.node_positions()[:, 2])[:3].tolist())
    edges = {tuple(sorted(c)) for c in CABLE_NODES.tolist()}
    assert all(tuple(sorted((a, b))) in edges for a in lowest for b in lowest if a < b)  # a closed face
    com = model.com()
    model.settle(2.0)
    assert np.linalg.norm(model.com() - com) < 1e-3
    assert np.abs(model.node_velocities()).max() < 1e-3
    assert np.all(model.tensions() >= 0.0) and model.tensions().max() < model.params["maxTens"]


def test_energy_is_conserved_without_damping_ground_and_gravity():
    space = ParameterSpace.t6()
    options = ModelOptions(gravity=0.0, ground=False, spin_damping=0.0)
    model = T6Model(space.replace(damping=0.0, motor_friction=0.0), options=options)
    rng = np.random.default_rng(3)
    model._set_velocities(rng.normal(0.0, 0.3, 36))
    model.step(None, n=1)
    e0 = model.energy()["total"]
    totals = []
    for _ in range(20):
        model.step(None, n=100)
        totals.append(model.energy()["total"])
    drift = np.abs(np.array(totals) - e0).max() / e0
    assert e0 > 1.0 and drift < 0.01, f"energy drift {drift:.4f} of {e0:.2f} J"
    # the motors never moved: nothing did work on the rest lengths
    np.testing.assert_array_equal(model.rest_length, model.build_rest_length)


def test_damping_dissipates_energy():
    options = ModelOptions(gravity=0.0, ground=False)
    model = T6Model(options=options)
    model._set_velocities(np.random.default_rng(3).normal(0.0, 0.3, 36))
    model.step(None, n=1)
    start = model.energy()
    totals = [start["total"]]
    for _ in range(10):
        model.step(None, n=50)
        totals.append(model.energy()["total"])
    assert np.all(np.diff(totals) < 1e-4 * start["total"])   # never gains energy (beyond integration error)
    assert totals[0] - totals[-1] > 0.1 * start["kinetic"]           # and loses a good part of the kick


def test_same_trajectory_bit_for_bit_in_process_and_across_processes(flop_data):
    again = simulate(controller=FlopController(heading=0.0), duration=3.0)
    np.testing.assert_array_equal(flop_data.nodes.values, again.nodes.values)
    code = textwrap.dedent("""
        import hashlib, numpy as np
        from physics import FlopController, simulate
        ds = simulate(controller=FlopController(heading=0.0), duration=3.0)
        print(hashlib.sha256(np.ascontiguousarray(ds.nodes.values).tobytes()).hexdigest())
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    import hashlib
    assert out.stdout.strip() == hashlib.sha256(np.ascontiguousarray(flop_data.nodes.values).tobytes()).hexdigest()


def test_same_seed_same_noise_other_seed_other_noise():
    a = simulate(duration=0.2, noise=0.001, seed=5)
    b = simulate(duration=0.2, noise=0.001, seed=5)
    c = simulate(duration=0.2, noise=0.001, seed=6)
    np.testing.assert_array_equal(a.nodes.values, b.nodes.values)
    assert not np.array_equal(a.nodes.values, c.nodes.values)
    assert "velocities" not in a       # a noisy recording is positions only


@pytest.mark.slow
def test_every_parameter_changes_a_flop_trajectory(space, flop_data):
    """Each of the 15 parameters moved by +5 % alone moves some node by > 10 µm within 3 s
    (numerical reproducibility is exact, so any change is the parameter's; measured figures in
    docs/physics.md: from 6e-5 m for motor_friction to 0.1 m for rod_length)."""
    for name in space.names:
        theta = space.replace(**{name: space[name].nominal * 1.05})
        ds = simulate(theta, controller=FlopController(heading=0.0), duration=3.0)
        moved = float(np.sqrt(((ds.nodes - flop_data.nodes) ** 2).sum("axis")).max())
        assert moved > 1e-5, f"{name}: max node change {moved:.2e} m"


def _progress_toward(ds, heading):
    com = ds["nodes"].mean("node").values[:, :2]
    goal = np.array([np.cos(heading), np.sin(heading)])
    return (com - com[0]) @ goal


@pytest.mark.slow
def test_flop_moves_the_centre_of_mass_toward_the_goal():
    """≥ 0.3 m toward the goal within 4 s at nominal θ and for ≥ 90 % of 20 random θ in the box."""
    heading = 0.0
    ds = simulate(controller=FlopController(heading=heading), duration=4.0)
    assert _progress_toward(ds, heading).max() >= 0.3
    thetas = ParameterSpace.t6().sample(20, seed=2026)
    progress = [_progress_toward(simulate(th, controller=FlopController(heading=heading), duration=4.0), heading).max()
                for th in thetas]
    assert np.mean(np.array(progress) >= 0.3) >= 0.9, f"progress per θ: {np.round(progress, 3)}"


@pytest.mark.slow
def test_flop_toward_any_heading_crosses_the_nearest_edge():
    """For any goal heading the robot flops over the base edge facing it: ≥ 0.3 m along that
    edge's normal and forward toward the goal. (One flop cannot give 0.3 m toward a goal 60° off
    every edge normal: 0.5 m x cos 60°; repeated flops correct the heading.)"""
    rng = np.random.default_rng(7)
    thetas = ParameterSpace.t6().sample(6, seed=11)
    for th, heading in zip(thetas, rng.uniform(-np.pi, np.pi, 6)):
        controller = FlopController(heading=heading)
        ds = simulate(th, controller=controller, duration=4.0)
        com = ds["nodes"].mean("node").values[:, :2]
        along_edge = ((com - com[0]) @ controller.plans[0].direction[:2]).max()
        assert along_edge >= 0.3 and _progress_toward(ds, heading).max() > 0.15


def test_flop_controller_plans_and_rests_afterwards():
    controller = FlopController(heading=1.0, flops=1)
    ds = simulate(controller=controller, duration=3.0)
    plan = controller.plans[0]
    assert len(plan.shorten) == 4 and len(plan.lengthen) == 4 and not set(plan.shorten) & set(plan.lengthen)
    assert np.all(plan.effect_shorten[list(plan.shorten)] > 0)
    com = ds["nodes"].mean("node").values
    assert np.linalg.norm(com[-1] - com[-11]) < 5e-3         # at rest again at the end (< 5 mm in 0.1 s)
    assert float(ds.tension.min()) >= 0.0


def test_motor_respects_speed_and_stall_limits():
    model = settled_model()
    readings = model.rest_length_readings().copy()
    target = readings.copy()
    target[0] -= 0.3                        # reel in 30 cm
    rest0 = model.rest_length[0]
    model.step(target, n=100)
    speed = (rest0 - model.rest_length[0]) / 0.1
    assert 0.0 < speed <= model.params["targetVelocity"] + 1e-9
    model.step(target, n=1000)              # long enough to stall against the tension limit
    assert model.tensions()[0] <= model.params["maxTens"] * 1.02


def test_divergence_is_reported():
    model = T6Model(options=ModelOptions(max_speed=0.5, drop_height=0.5))
    with pytest.raises(PhysicsError, match="diverged"):
        model.settle(1.0)


@pytest.mark.parametrize("kwargs, match", [
    (dict(dt=0.0), "dt must be in"),
    (dict(friction=-1.0), "friction must be"),
    (dict(face=9), "face must be"),
    (dict(max_speed=0.0), "max_speed"),
])
def test_model_options_validation(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        ModelOptions(**kwargs)


def test_model_and_simulate_validation():
    with pytest.raises(ParameterError, match="MotorGains.kp"):
        MotorGains(kp=-1.0)
    with pytest.raises(ParameterError, match="exceeds the cable length"):
        T6Model(ParameterSpace.t6().replace(pretension=2000.0))
    with pytest.raises(ParameterError, match="whole number of physics steps"):
        simulate(duration=0.1, sample_rate=300.0, options=ModelOptions(dt=0.002))
    with pytest.raises(ParameterError, match="explicit seed"):
        simulate(duration=0.1, noise=0.01)
    with pytest.raises(ParameterError, match="duration"):
        simulate(duration=-1.0)
    with pytest.raises(PhysicsError, match="24 finite target"):
        T6Model().step(np.ones(3))
    with pytest.raises(ControllerError, match="change must be"):
        FlopController(change=0.9)
    with pytest.raises(ControllerError, match="start < stop <= period"):
        FlopController(start=2.0, stop=1.0)
    with pytest.raises(ParameterError, match="T6 parameters"):
        from physics import Parameter
        T6Model(space=ParameterSpace((Parameter("m", "kg", 1.0, 0.5, 2.0),)))


def test_replaying_recorded_controls_reproduces_the_trajectory(flop_data):
    """The flop controller's commands, replayed open loop at the same θ, give the same motion."""
    replay = simulate(controller=ReplayController(flop_data.time.values, flop_data.controls.values), duration=3.0)
    np.testing.assert_array_equal(replay.nodes.values, flop_data.nodes.values)
    of = ReplayController.of(flop_data.transpose("cable", "time", ...))     # any dimension order
    np.testing.assert_array_equal(of.controls, flop_data.controls.transpose("time", "cable").values)
    with pytest.raises(ControllerError, match="shape"):
        ReplayController(flop_data.time.values, flop_data.controls.values[:, :3])
    with pytest.raises(ControllerError, match="no controls"):
        ReplayController.of(flop_data.drop_vars("controls"))


def test_hold_controller_keeps_rest_lengths():
    ds = simulate(controller=HoldController(), duration=0.5)
    rest = ds.rest_length.values
    assert np.abs(rest - rest[0]).max() == 0.0
    assert np.abs(ds.controls.values - rest[0]).max() == 0.0
