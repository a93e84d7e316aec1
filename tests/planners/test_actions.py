"""Flop actions: validation, candidate sets, the three edge headings, and the n-cable re-selection."""
from __future__ import annotations

import numpy as np
import pytest

from physics.controllers import FlopController
from planners import ActionError, FlopAction, RobotStart, candidate_actions, face_headings
from physics.controllers import select_cables
from planners.rollouts import place, plan_cables


@pytest.mark.parametrize("kw, match", [({"change": 0.6}, "change must be"), ({"n_cables": 0}, "n_cables"),
                                       ({"n_cables": 2.5}, "n_cables"), ({"stop": 3.0}, "start < stop <= duration"),
                                       ({"start": 1.5}, "start < stop"), ({"heading": float("inf")}, "finite")])
def test_bad_actions(kw, match) -> None:
    args = {"heading": 0.0, **kw}
    with pytest.raises(ActionError, match=match):
        FlopAction(**args)


def test_action_makes_its_controller() -> None:
    a = FlopAction(-0.5, 0.25, 3, start=0.1, stop=0.9, duration=1.5)
    c = a.controller()
    assert isinstance(c, FlopController) and c.change == 0.25 and c.n_cables == 3 and c.period == 1.5
    assert 0 <= a.heading < 2 * np.pi and c.heading == pytest.approx(2 * np.pi - 0.5)


def test_candidate_sets() -> None:
    acts = candidate_actions(6, changes=(0.2, 0.3), n_cables=(3,))
    assert len(acts) == 12 and len(set(acts)) == 12
    assert len(candidate_actions([0.0, 2 * np.pi], changes=(0.2,), n_cables=(4,))) == 1   # same heading mod 2π
    with pytest.raises(ActionError, match="non-empty"):
        candidate_actions(3, changes=())
    with pytest.raises(ActionError, match="needs headings"):
        candidate_actions()


def test_face_headings_and_plan_reselection() -> None:
    start = RobotStart.settled()
    h = face_headings(start.nodes)
    gaps = np.diff(np.r_[h, h[0] + 2 * np.pi])
    assert h.shape == (3,) and np.all(gaps > np.radians(90)) and np.all(gaps < np.radians(150))
    acts = candidate_actions(nodes=start.nodes, changes=(0.2,), n_cables=(4,))
    assert len(acts) == 3
    # the controller tips the robot across the edge a heading points at: all three edges differ
    p4 = plan_cables(FlopAction(h[0], 0.2, 4), start)
    p2 = plan_cables(FlopAction(h[0], 0.2, 2), start)
    again = select_cables(p4, 2)
    assert again.shorten == p2.shorten and again.lengthen == p2.lengthen
    assert len(set(p4.shorten) & set(p4.lengthen)) == 0
    model = place(None, start)
    assert model.node_positions()[:, 2].min() >= model.setup.cap_radius
