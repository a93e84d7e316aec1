"""Robust planning: CVaR on known numbers, the risk measures' choices, typed errors, determinism, parallel = serial."""
from __future__ import annotations

import numpy as np
import pytest

from belief.belief import Belief
from belief.grid import Grid
from embeddings import Identity
from physics.parameters import Parameter, ParameterSpace
from planners import (
    EmptyBeliefError, FlopAction, GoalError, LevelError, Outcome, PointBelief, RobotMismatchError, RobotStart,
    RolloutSet, check_belief, cvar, plan_flop, progress, rollouts, score,
)
from planners.robust import check_goal


def test_cvar_known_numbers() -> None:
    x = np.arange(10, 0, -1, dtype=float)          # 10 .. 1, unsorted on purpose
    assert cvar(x, 0.2) == pytest.approx(1.5)      # mean of the worst 2
    assert cvar(x, 0.25) == pytest.approx((1 + 2 + 0.5 * 3) / 2.5)
    assert cvar(x, 1.0) == pytest.approx(5.5)
    assert cvar(x, 1e-6) == pytest.approx(1.0)
    levels = np.linspace(0.05, 1.0, 20)
    assert np.all(np.diff([cvar(x, a) for a in levels]) >= -1e-12)    # non-decreasing in α


@pytest.mark.parametrize("bad", [0.0, -0.1, 1.5, float("nan"), True, "0.2"])
def test_bad_level(bad) -> None:
    with pytest.raises(LevelError, match=r"level α must be a number in \(0, 1\]"):
        cvar(np.ones(3), bad)


def test_progress_formula() -> None:
    d = np.array([[0.5, 0.0], [0.0, 0.5], [0.5, 0.0]])
    p = progress(d, np.array([True, True, False]), np.zeros(2), np.array([1.0, 0.0]))
    assert p == pytest.approx([0.5, 1.0 - np.sqrt(1.25), 0.0])


def _outcome(dx: float, flopped: bool = True) -> Outcome:
    nodes = np.zeros((1, 12, 3))
    return Outcome(np.array([dx, 0.0]), (1, 2, 3) if flopped else (0, 4, 10), None, nodes)


def _set(rows: list[list[float]]) -> RolloutSet:
    start = RobotStart.settled()                   # face (0, 4, 10), centre near the origin
    start = RobotStart(np.array(start.nodes) - np.r_[start.centre, 0.0], start.readings)
    outs = tuple(tuple(_outcome(v, v > 0) for v in row) for row in rows)
    acts = tuple(FlopAction(0.1 * k) for k in range(len(rows)))
    return RolloutSet(acts, np.zeros((len(rows[0]), 15)), outs, (None,) * len(rows), start)


def test_risk_measures_trade_mean_for_tail() -> None:
    rs = _set([[0.7, 0.7, 0.0], [0.4, 0.4, 0.4]])   # action 0: better mean, fails once; action 1: safe
    goal = np.array([5.0, 0.0])
    assert np.argmax(score(rs, goal, risk="expected")[0]) == 0
    assert np.argmax(score(rs, goal, risk="cvar", level=1 / 3)[0]) == 1
    s, _, success = score(rs, goal, risk="success", threshold=0.2)
    assert np.argmax(s) == 1 and success.mean(axis=1) == pytest.approx([2 / 3, 1.0])


@pytest.mark.parametrize("goal, match", [((np.nan, 0.0), "finite point"), ((1.0, 2.0, 3.0), "finite point"),
                                         ((0.1, 0.0), "already reached"), ((50.0, 0.0), "beyond max_distance")])
def test_bad_goals(goal, match) -> None:
    with pytest.raises(GoalError, match=match):
        check_goal(goal, np.zeros(2), radius=0.3, max_distance=20.0)


def test_belief_from_another_robot_and_empty_belief(belief4) -> None:
    space = ParameterSpace(tuple(Parameter(f"x{i}", "m", 0.5, 0.0, 1.0, minimum=-1.0) for i in range(2)))
    dec = Identity(space)
    grid = Grid.for_decoder(dec, points_per_dim=3)
    other = Belief.from_posterior(grid.to_dataarray(np.full(9, 1 / 9), name="P"), dec, grid)
    with pytest.raises(RobotMismatchError, match="identify on trajectories of this robot"):
        check_belief(other)
    empty = PointBelief(ParameterSpace.t6().nominal)
    empty.p = np.zeros(0)
    with pytest.raises(EmptyBeliefError, match="run an identification"):
        check_belief(empty)
    with pytest.raises(EmptyBeliefError, match="samples must be an integer >= 1"):
        plan_flop(belief4, RobotStart.settled(), (2.0, 0.0), actions=[FlopAction(0.0)], samples=0)


def test_plan_is_deterministic_for_a_seed(belief4) -> None:
    start = RobotStart.settled()
    acts = [FlopAction(0.3, 0.3, 4, stop=0.8, duration=1.0), FlopAction(0.3, 0.3, 2, stop=0.8, duration=1.0)]
    a = plan_flop(belief4, start, (2.0, 1.0), actions=acts, samples=3, seed=7)
    b = plan_flop(belief4, start, (2.0, 1.0), actions=acts, samples=3, seed=7)
    assert a.index == b.index and np.array_equal(a.scores, b.scores) and np.array_equal(a.progress, b.progress)
    assert np.array_equal(a.rollouts.thetas, belief4.sample(3, seed=7))


def test_parallel_rollouts_equal_serial() -> None:
    space = ParameterSpace.t6()
    thetas = np.vstack([space.nominal, space.sample(1, seed=2)])
    act = [FlopAction(1.0, 0.3, 4, stop=0.6, duration=0.8)]
    start = RobotStart.settled()
    serial = rollouts(act, start, thetas, n_workers=0)
    parallel = rollouts(act, start, thetas, n_workers=2)
    assert np.array_equal(serial.displacement, parallel.displacement)
    assert [o.face for o in serial.outcomes[0]] == [o.face for o in parallel.outcomes[0]]
