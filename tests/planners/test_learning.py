"""Learning while planning: an executed flop moves P to the cell that predicted it, and the
multi-step planner plans on the re-weighed cells."""
from __future__ import annotations

import numpy as np
import pytest

from planners import FlopAction, PlannerError, PointBelief, SimulatedRobot, plan_to_goal
from planners.learning import FlopEvidence
from planners.rollouts import plan_cables


def test_an_executed_flop_moves_p_to_the_cell_that_predicted_it(dynamic_cells) -> None:
    b = dynamic_cells
    robot = SimulatedRobot(b.theta[2])
    flop = FlopAction(0.3, 0.3, 4, stop=0.8, duration=1.0)
    ev = FlopEvidence(b, cells=3, how="top", sigma=0.005)
    start = robot.observe()
    h = ev.update(flop, start, robot.execute(flop, plan_cables(flop, start)))
    assert int(np.argmax(ev.weights)) == 2 and ev.weights[2] > 0.6
    assert h == pytest.approx(ev.entropy) and h < np.log(3) - 0.1
    assert len(ev.history) == 2 and np.allclose(ev.history[0], 1 / 3)
    assert np.allclose(ev.belief().p[ev.cells], ev.weights)
    with pytest.raises(PlannerError, match="sigma must be a noise std > 0 m"):
        FlopEvidence(b, sigma=0.0)


def test_the_goal_planner_learns_from_each_flop_and_a_point_belief_does_not(dynamic_cells) -> None:
    b = dynamic_cells
    kw = dict(radius=0.3, max_steps=2, samples=2, horizon=1, progress=False,
              actions_kw={"changes": (0.3,), "n_cables": (4,), "stop": 0.8, "duration": 1.0})
    goal = SimulatedRobot(b.theta[2]).centre + [2.5, 0.0]
    run = plan_to_goal(b, b.theta[2], goal, learn=True, cells=3, sigma=0.005, **kw)
    assert len(run.steps) == 2 and run.steps[0].entropy is not None and run.steps[0].entropy < np.log(3)
    assert run.steps[1].entropy is None                                 # no update after the last flop
    fixed = plan_to_goal(b, b.theta[2], goal, learn=False, **kw)
    point = plan_to_goal(PointBelief(b.theta[2]), b.theta[2], goal, learn=True, **kw)
    assert all(s.entropy is None for s in fixed.steps + point.steps)
