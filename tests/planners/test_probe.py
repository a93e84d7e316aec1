"""Active identification: the gain estimator's bounds, the update, a separating probe beats a
non-separating one, the posterior moves to the true cell, the stopping rule, typed errors."""
from __future__ import annotations

import numpy as np
import pytest

from planners import EmptyBeliefError, FlopAction, PlannerError, RobotStart, information_gain, probe, rollouts
from planners.probe import noise_scale, observations, restricted_belief, support, update_weights


def test_gain_is_zero_for_equal_predictions_and_entropy_for_separated_ones() -> None:
    w = np.array([0.5, 0.25, 0.25])
    ok = np.ones(3, dtype=bool)
    same = np.zeros((3, 10))
    far = np.eye(3, 10) * 100.0
    assert information_gain(same, ok, w, 1.0) == pytest.approx(0.0, abs=1e-12)
    assert information_gain(far, ok, w, 1.0) == pytest.approx(-(w * np.log(w)).sum())
    gains = [information_gain(np.eye(3, 10) * s, ok, w, 1.0) for s in (0.5, 1.0, 2.0, 4.0)]
    assert np.all(np.diff(gains) > 0)                                   # more separation, more gain
    # a diverged prediction is its own observation: it separates that cell completely
    assert information_gain(same, np.array([True, True, False]), w, 1.0) == pytest.approx(
        -(0.75 * np.log(0.75) + 0.25 * np.log(0.25)))


def test_update_moves_mass_to_the_nearest_prediction() -> None:
    F = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    w = update_weights(np.full(3, 1 / 3), F, np.ones(3, bool), np.array([0.9, 0.05]), True, 0.05)
    assert np.argmax(w) == 1 and w.sum() == pytest.approx(1.0) and w[1] > 0.99
    w = update_weights(np.full(3, 1 / 3), F, np.array([True, False, True]), np.array([1.0, 0.0]), True, 10.0)
    assert w[1] == 0.0


def test_separating_probe_gains_more_and_the_update_finds_the_true_cell(dynamic_cells) -> None:
    b = dynamic_cells
    flop = FlopAction(0.3, 0.3, 4, stop=0.8, duration=1.0)
    hold = FlopAction(0.3, 0.01, 1, stop=0.3, duration=1.0)       # barely moves
    F, ok = observations(rollouts([flop, hold], RobotStart.settled(), b.theta))
    w = np.full(3, 1 / 3)
    g_flop, g_hold = (information_gain(F[a], ok[a], w, noise_scale(F[a], ok[a], 0.005)) for a in range(2))
    assert g_flop > 0.2 and g_flop > 100 * g_hold and g_flop <= np.log(3) + 1e-9
    run = probe(b, b.theta[2], steps=1, cells=3, how="top", actions=[flop], sigma=0.005, progress=False)
    assert run.stopped == "steps" and len(run.steps) == 1
    assert np.argmax(run.belief.p) == 2 and run.belief.p[2] > 0.6
    assert run.steps[0].entropy_after < run.steps[0].entropy_before


def test_stops_when_no_probe_teaches_enough_and_validates(belief4) -> None:
    hold = FlopAction(0.3, 0.01, 1, stop=0.3, duration=0.5)
    run = probe(belief4, None, steps=3, cells=4, how="top", actions=[hold], min_gain=10.0, progress=False)
    assert run.stopped == "no gain" and run.steps == () and run.belief.p.sum() == pytest.approx(1.0)
    with pytest.raises(PlannerError, match="unknown: \\['stiffness'\\]"):
        probe(belief4, None, targets=["stiffness"], progress=False)
    with pytest.raises(EmptyBeliefError, match="cells must be an integer >= 1"):
        support(belief4, 0, seed=0)
    idx, w = support(belief4, 50, seed=3)
    assert np.array_equal(idx, support(belief4, 50, seed=3)[0]) and w.sum() == pytest.approx(1.0)


def test_a_collapse_onto_one_probed_cell_identifies_nothing(make_belief) -> None:
    from planners.probe import MIN_CELLS

    belief = make_belief(16)
    cells = np.arange(12)
    collapsed = restricted_belief(belief, cells, np.r_[0.97, np.full(11, 0.03 / 11)])
    assert set(collapsed.verdict) == {"not identified"}
    assert all("effective cells" in r for r in collapsed.reason)
    spread = restricted_belief(belief, cells, np.full(12, 1 / 12))     # 12 effective cells >= MIN_CELLS
    assert 12 >= MIN_CELLS and not all("effective cells" in r for r in spread.reason)
