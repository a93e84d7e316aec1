"""The mismatch stage (criticism.mismatch) and its components (physics.effects.actuation, anchors).

Laws: the tension-limited actuator moves a rest length by at most targetVelocity·dt per step and
never winds a cable past maxTens; with it a slack cable still never pushes. Cable anchors off the
axis are internal forces (no net force on the robot), a slack cable gets no anchor force, offset 0
is the bare T6, and the effect refuses to lose its actuator.

Target, small: on 1 s flops of the foreign testbed's nominal robot (Bullet), fitted on one flop
and scored on the held-out flop, the stage keeps the default components (the tension-limited
actuator, anchors, rolling resistance), puts the anchors clearly off the axis (the testbed's are
6 cm off; DART's approximation of them fits 3-6 cm), and cuts the held-out one-step error and the
drift at 0.5 s to at most 0.5 of the re-tuned bare model's, the issue's target (measured here at
0.44 and 0.34 with 3 least-squares evaluations; without rolling resistance 0.50 and 0.45;
benchmarks/mismatch.py measures it on 3 s flops). On DART's own flops it keeps nothing.
"""
from __future__ import annotations

import numpy as np
import pytest

from belief.least_squares import LeastSquaresConfig
from criticism.diagnose import split_masks
from criticism.mismatch import MismatchConfig, Trial, _choose, absorb_mismatch, superseded
from physics import FlopController, TrajectoryObjective, load_trajectory, simulate
from physics.actuators import MotorGains, tension_limited_step
from physics.effects import (
    CableAnchors,
    CylinderCaps,
    EndCapRadius,
    FixedCableAnchors,
    RateLimitedActuation,
    RollingResistance,
    TensionLimitedActuation,
    model_space,
)
from physics.effects.anchors import anchor_forces
from physics.geometry import node_positions
from physics.tensegrity import T6Model

SMALL = LeastSquaresConfig(evaluations=3)


def test_tension_limited_step_follows_rate_and_cap() -> None:
    rest, speed = np.full(3, 1.0), np.zeros(3)
    target = np.array([0.5, 1.5, 0.5])
    tension = np.array([100.0, 100.0, 400.0])      # the third cable is above maxTens = 300 N
    tension_limited_step(rest, speed, target, tension, 1.5, 300.0, 800.0, 0.01, 1e-3)
    assert rest[0] == pytest.approx(1.0 - 1.5e-3) and rest[1] == pytest.approx(1.0 + 1.5e-3)
    assert rest[2] > 1.0                           # pays out instead of winding past the cap
    assert np.all(np.abs(speed) <= 1.5 + 1e-12)


def test_tension_limited_model_never_pushes() -> None:
    effects = [TensionLimitedActuation()]
    model = T6Model(model_space(effects).nominal, effects=effects)
    model.settle(0.3)
    target = model.rest_length_readings() * np.r_[np.full(12, 0.7), np.full(12, 1.3)]
    for _ in range(40):
        model.step(target, n=10)
        slack = model.cable_lengths() <= model.rest_length
        assert np.all(model.tensions() >= 0) and np.all(model.tensions()[slack] == 0)


def test_anchor_forces_are_internal_and_never_push() -> None:
    nodes = node_positions(1.74, 0.45) + np.random.default_rng(0).normal(0, 0.01, (12, 3))
    tension = np.linspace(0.0, 250.0, 24)
    out = np.zeros((12, 3))
    anchor_forces(nodes, tension, 0.06, 800.0, np.zeros(24), out)
    assert np.allclose(out.sum(axis=0), 0.0, atol=1e-9)
    slack = np.zeros((12, 3))
    anchor_forces(nodes, np.zeros(24), 0.06, 800.0, np.zeros(24), slack)
    assert np.all(slack == 0.0)


def test_anchors_at_zero_offset_are_the_bare_model() -> None:
    effects = [CableAnchors()]
    bare, anchored = T6Model(), T6Model(model_space(effects).nominal, effects=effects)
    bare.settle(0.2)
    anchored.settle(0.2)
    assert np.allclose(bare.node_positions(), anchored.node_positions(), atol=1e-9)


@pytest.mark.parametrize("anchors", [CableAnchors(), FixedCableAnchors()], ids=lambda e: e.name)
def test_anchors_act_from_the_first_step_whatever_the_actuator(anchors) -> None:
    """A freshly placed model and one that has stepped before and is set to the same state take the
    same next steps: the anchors re-route the cables from the first step on, listed before or after
    an effect that replaces the actuator."""
    runs = []
    for effects in ([anchors, RateLimitedActuation()], [RateLimitedActuation(), anchors]):
        space = model_space(effects)
        theta = space.as_array({**space.as_dict(None), anchors.parameters()[0].name: 0.05})
        fresh, stepped = T6Model(theta, effects=effects), T6Model(theta, effects=effects)
        fresh.set_nodes(node_positions(1.74, 0.45) + [0.0, 0.0, 1.0])
        stepped.step(None, n=3)
        stepped.set_state(fresh.get_state())
        for model in (fresh, stepped):
            model.step(None, n=5)
        assert np.array_equal(fresh.node_positions(), stepped.node_positions())
        runs.append(fresh.node_positions())
    assert np.allclose(runs[0], runs[1], atol=1e-12)


def test_superseded_drops_other_actuators() -> None:
    kept = [TensionLimitedActuation()]
    names = [e.name for e in superseded([RateLimitedActuation(), CableAnchors(), TensionLimitedActuation()], kept)]
    assert names == ["cable_anchors"]
    assert MotorGains().kp > 0       # the motor model stays the default actuator
    anchors = superseded([FixedCableAnchors(), CylinderCaps()], [CableAnchors()])
    assert [e.name for e in anchors] == ["cylinder_caps"]     # one anchor law in a model


def test_stage_refuses_a_component_whose_local_law_the_data_contradict() -> None:
    """A component with the larger windowed gain whose one-step error on the fit flops rises past
    ``max_one_step_rise`` (end caps 2 cm smaller than the robot's: every resting node sinks) is
    passed over for the next by gain (anchors at offset 0: the same model, ratio 1); a trial under
    ``min_gain`` is never asked; with the guard wide open the larger gain wins."""
    data = [simulate(controller=FlopController(heading=0.3), duration=0.4, noise=2e-4, seed=0)]
    model = TrajectoryObjective(data, horizon=25, loss="squared", n_workers=0)
    theta = model.space.nominal
    tried = []
    trials = ((EndCapRadius(), -0.02, 0.5), (CableAnchors(), 0.0, 0.2), (RollingResistance(), 0.0, 0.05))
    for effect, value, gain in trials:
        extended = model.with_effects((effect,))
        trial = Trial(1, effect.name, {}, 1.0, gain, False, tuple(np.r_[theta, value]))
        tried.append((trial, extended))
    kept, rises = _choose(model, theta, tried, MismatchConfig())
    assert kept == 1 and set(rises) == {0, 1}, rises
    assert rises[0] > 1.1 and rises[1] == pytest.approx(1.0, abs=1e-9), rises
    assert _choose(model, theta, tried, MismatchConfig(max_one_step_rise=1e6))[0] == 0


def _stage(data: list, components: tuple, rounds: int):
    objective = TrajectoryObjective(data, horizon=25, loss="squared", n_workers=0)
    fit, _ = split_masks(objective.segments, [1])
    config = MismatchConfig(components=components, rounds=rounds, local=SMALL)
    return absorb_mismatch(objective, fit, [1], config=config, progress=False)


@pytest.mark.slow
def test_stage_absorbs_the_testbed_mismatch(tmp_path) -> None:
    from testbed.datasets import make_dataset
    from testbed.record import Observation
    paths = make_dataset("nominal", 0, tmp_path, obs=Observation(noise=2e-4), duration=1.0)
    files = {p.stem: p for p in paths}
    data = [load_trajectory(files[k]) for k in ("flop_0", "heldout_0")]
    report = _stage(data, (TensionLimitedActuation(), CableAnchors(), RollingResistance()), rounds=3)
    assert {e.name for e in report.effects} == {"tension_limited_actuator", "cable_anchors", "rolling_resistance"}
    offset = report.theta[list(report.names).index("anchor_offset")]
    assert 0.015 <= offset <= 0.09, offset
    ratios = report.ratios()
    assert ratios["one_step"] <= 0.5 and ratios["drift"] <= 0.5, ratios


@pytest.mark.slow
def test_stage_keeps_nothing_on_its_own_engine() -> None:
    data = [simulate(controller=FlopController(heading=h), duration=1.0, noise=2e-4, seed=k)
            for k, h in enumerate((0.3, 2.4))]
    report = _stage(data, (TensionLimitedActuation(), CableAnchors(), RollingResistance()), rounds=1)
    assert max(t.gain for t in report.trials) < 0.1
    assert report.effects == (), report.text()


@pytest.mark.slow
def test_stage_on_the_third_engine_takes_its_anchors_and_leaves_bullets_rolling_friction(tmp_path) -> None:
    """The same robot in MuJoCo (held back from the stage's development; no rolling friction there):
    the stage keeps the actuator law and the rim anchors, at an offset near the true 6 cm rim, and
    rolling resistance, which Bullet's data need, does not pay."""
    from testbed.datasets import make_dataset
    from testbed.record import Observation
    paths = make_dataset("nominal", 0, tmp_path, obs=Observation(noise=2e-4), duration=1.0, engine="mujoco")
    files = {p.stem: p for p in paths}
    data = [load_trajectory(files[k]) for k in ("flop_0", "heldout_0")]
    report = _stage(data, (TensionLimitedActuation(), CableAnchors(), RollingResistance()), rounds=3)
    kept = {e.name for e in report.effects}
    assert {"tension_limited_actuator", "cable_anchors"} <= kept and "rolling_resistance" not in kept, report.text()
    offset = report.theta[list(report.names).index("anchor_offset")]
    assert 0.04 <= offset <= 0.08, offset
    ratios = report.ratios()
    assert ratios["drift"] <= 0.5, ratios
