"""The testbed's hidden effects expressed in the catalog's laws (benchmarks/effects_table.catalog_equivalent),
checked against both laws themselves."""
from __future__ import annotations

import numpy as np
from effects_table import catalog_equivalent, summarize
from testbed.effects import Effects
from testbed.params import NOMINAL
from testbed.robot import TestbedRobot

from physics import ParameterSpace
from physics.cables import cable_tension
from physics.effects.forces import viscous_drag_forces


def test_the_testbeds_hysteresis_is_the_catalogs_at_the_equivalent_size() -> None:
    """Cables the testbed softens by h_t while shortening pull as the catalog's with stiffness
    (1 - h_t) k and hysteresis h_t / (1 - h_t) (the high end), lengthening and shortening, dampers
    included; at the box's lowest stiffness the low end matches the lengthening branch."""
    h_t = 0.3
    robot = TestbedRobot(NOMINAL, Effects(hysteresis=h_t))
    low, high = catalog_equivalent("cable_hysteresis", {"hysteresis": h_t})
    t6 = ParameterSpace.t6()
    k_lo = t6.lower[t6.index("stiffnessActive")]
    try:
        length = robot.rest + 0.04
        for rate in (-0.5, -0.2, 0.2, 0.5):                # m/s, far from the catalog's smoothing (0.01 m/s)
            robot.last_length = length - rate * robot.dt
            testbed = robot.cable_forces(length)
            catalog = [cable_tension(0.04, rate, (1 - h_t) * robot.k, robot.c, 0.0, high) for _ in testbed]
            np.testing.assert_allclose(testbed, catalog, rtol=1e-9)
            if rate > 0:
                np.testing.assert_allclose(testbed, cable_tension(0.04, rate, k_lo, robot.c, 0.0, low), rtol=1e-9)
    finally:
        robot.close()


def test_the_testbeds_drag_is_the_catalogs_viscous_drag_at_the_same_coefficient() -> None:
    """The testbed's rod ends feel -d v (its own code, summed into each rod's force and torque);
    the catalog's ViscousDrag at c = d gives the same wrench on every rod of a moving robot."""
    robot = TestbedRobot(NOMINAL, Effects(drag=3.0))
    try:
        for _ in range(150):                               # falls onto the ground and rocks: rods move and spin
            robot.step(robot.rest)
        poses = robot._poses()
        net, torque = np.zeros((6, 3)), np.zeros((6, 3))
        robot._node_forces(poses, net, torque)
        nodes, velocities = robot.nodes(poses), robot.node_velocities(poses)
        c = catalog_equivalent("viscous_drag", {"drag": 3.0})
        assert c == (3.0, 3.0)
        forces = np.zeros((12, 3))
        viscous_drag_forces(velocities, c[0], forces)
        rods = np.arange(12) // 2
        assert np.abs(velocities).max() > 0.05
        np.testing.assert_allclose(net, forces.reshape(6, 2, 3).sum(axis=1), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(torque, np.cross(nodes - poses[2][rods], forces).reshape(6, 2, 3).sum(axis=1),
                                   rtol=1e-9, atol=1e-12)
    finally:
        robot.close()


def test_a_law_without_a_map_has_no_equivalent() -> None:
    assert catalog_equivalent("ground_viscosity", {"ground_viscosity": 150.0}) is None
    assert catalog_equivalent("air_drag", {"drag": 3.0}) is None      # needs the row's flops


def _row(seed: int, verdict: str, lower: float, upper: float) -> dict:
    """A testbed row whose found hysteresis was re-identified in [lower, upper] with ``verdict``."""
    return {"scenario": "hysteresis", "seed": seed, "held_out": "testbed", "truth": ["cable_hysteresis"],
            "top": "cable_hysteresis", "top_values": {"hysteresis": 0.3}, "true_values": {"hysteresis": 0.3},
            "found": ["cable_hysteresis"], "top_explained": 0.5, "held_before": 1.0, "held_after": 0.4,
            "estimates": {"hysteresis": {"value": 0.5 * (lower + upper), "lower": lower, "upper": upper,
                                         "verdict": verdict}}}


def test_the_tally_counts_intervals_and_claims_that_miss(capsys) -> None:
    """Intervals against the catalog-law truth 0.11-0.43: two hold it, one claim misses it, and a
    miss called "not identified" is no claim; the delay's truth is its own law's."""
    summarize([_row(0, "identified", 0.2, 0.3), _row(1, "identified", 0.5, 0.6),
               _row(2, "not identified", 0.45, 0.6), _row(3, "weakly identified", 0.0, 0.9)])
    out = capsys.readouterr().out
    assert "intervals that meet the catalog-law truth: 2 of 4; claims (identified) that miss it: 1 of 2" in out
    assert catalog_equivalent("actuator_delay", {"actuator_delay": 0.05}) == (0.05, 0.05)


def test_either_drag_law_counts_as_the_drag_ranked_first_and_found(capsys) -> None:
    """The testbed's drag is linear (viscous_drag); the quadratic air_drag ranked first and found
    counts as the cause found, a ground slope does not, and its size is shown in both laws."""
    row = {"scenario": "drag", "seed": 0, "held_out": "heading", "truth": ["viscous_drag"], "top": "air_drag",
           "top_values": {"drag": 1.5}, "true_values": {"drag": 3.0}, "found": ["air_drag"], "top_explained": 0.47,
           "held_before": 1.0, "held_after": 0.53}
    wrong = {**row, "seed": 1, "top": "ground_slope", "found": ["ground_slope"], "top_values": {"slope_x": 0.01}}
    summarize([row, wrong])
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("drag "))
    assert line.split()[1:5] == ["2", "1", "1", "1"]             # seeds, top=true, named, found


def test_the_fit_column_compares_testbed_rows_with_the_testbeds_truth(capsys) -> None:
    """On a testbed row the "criticism fit (true)" column shows the testbed's 50 ms delay, not the
    own-engine scenario's 80 ms."""
    row = {"scenario": "actuator_delay", "seed": 0, "held_out": "testbed", "truth": ["actuator_delay"],
           "top": "actuator_delay", "top_values": {"actuator_delay": 0.049}, "true_values": {"actuator_delay": 0.05},
           "found": ["actuator_delay"], "top_explained": 0.5, "held_before": 1.0, "held_after": 0.5}
    summarize([row])
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("actuator_delay "))
    assert line.split()[-3:-1] == ["0.049", "(0.05)"]
    summarize([{**row, "held_out": "heading"}])
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("actuator_delay "))
    assert line.split()[-3:-1] == ["0.049", "(0.08)"]
