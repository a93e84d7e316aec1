"""Two-flop lookahead: flops to go on hand-made outcomes, and the nudge it stops preferring."""
from __future__ import annotations

import numpy as np
import pytest

from planners import FlopAction, Outcome, RobotStart, RolloutSet, score
from planners.actions import face_headings
from planners.errors import PlannerError
from planners.lookahead import (DEFAULT_FLOP_LENGTH, TIE_BREAK, distance_to_disc, flop_length, flops_to_go,
                                 next_flops)


def _start() -> RobotStart:
    s = RobotStart.settled()
    return RobotStart(np.array(s.nodes) - np.r_[s.centre, 0.0], s.readings)      # centre at the origin


def _set(rows: list[list[tuple[float, bool]]]) -> RolloutSet:
    """Outcomes (dx, flopped) along +x; the landing keeps the start's nodes (its face headings)."""
    start = _start()

    def outcome(dx: float, flopped: bool) -> Outcome:
        face = (1, 2, 3) if flopped else start.face
        return Outcome(np.array([dx, 0.0]), face, None, np.zeros((1, 12, 3)))

    outs = tuple(tuple(outcome(*o) for o in row) for row in rows)
    acts = tuple(FlopAction(0.1 * k) for k in range(len(rows)))
    return RolloutSet(acts, np.zeros((len(rows[0]), 15)), outs, (None,) * len(rows), start)


def test_distance_to_the_disc_is_zero_inside_and_grows_outside() -> None:
    d = distance_to_disc(np.array([[0.0, 0.0], [0.9, 0.0], [3.0, 4.0]]), np.zeros(2), 1.0)
    assert d == pytest.approx([0.0, 0.0, 4.0])


def test_flops_to_go_formula() -> None:
    goal, r = np.array([1.0, 0.0]), 0.5
    rs = _set([[(0.8, True), (0.6, True), (0.05, False)]])
    L = flop_length(rs)
    assert L == pytest.approx(0.7)                                  # median of the two flops that changed face
    h = face_headings(rs.start.nodes)
    c1 = np.array([0.05, 0.0])
    nxt = c1 + L * np.column_stack([np.cos(h), np.sin(h)])
    expected_nudge = (1 + min(float(distance_to_disc(c1, goal, r)), distance_to_disc(nxt, goal, r).min()) / L
                      + TIE_BREAK * np.linalg.norm(goal - nxt, axis=1).min() / L)
    assert flops_to_go(rs, goal, r)[0] == pytest.approx([0.0, 0.0, expected_nudge])
    assert flop_length(_set([[(0.05, False)]])) == DEFAULT_FLOP_LENGTH
    with pytest.raises(PlannerError, match="radius"):
        flops_to_go(rs, goal, -1.0)


def test_the_lookahead_prefers_a_flop_into_the_disc_to_a_safe_nudge() -> None:
    """Action 0 nudges 5 cm every time; action 1 flops into the disc twice and once 0.3 m backwards.
    CVaR_0.5 of one-flop progress takes the nudge (a sure 5 cm); flops to go take the flop (the
    nudge always costs a flop, the flop costs none two times in three)."""
    goal = np.array([0.9, 0.0])
    rs = _set([[(0.05, False)] * 3, [(0.7, True), (0.7, True), (-0.3, True)]])
    one = score(rs, goal, risk="cvar", level=0.5, horizon=1)[0]
    two = score(rs, goal, risk="cvar", level=0.5, horizon=2, radius=0.5)[0]
    assert np.argmax(one) == 0 and np.argmax(two) == 1
    assert np.all(two <= 0)                                          # −flops to go
    with pytest.raises(PlannerError, match="horizon"):
        score(rs, goal, horizon=3)


def test_simulated_next_flops_replace_the_geometric_guess() -> None:
    """Δ₂ given for the start's face: an outcome that stays lands where Δ₂ says, not at L n_e."""
    goal, r = np.array([1.0, 0.0]), 0.3
    rs = _set([[(0.05, False), (0.6, True)]])
    face = tuple(rs.start.face)
    into = {face: np.array([[0.9, 0.0], [np.nan, np.nan], [-0.5, 0.0]])}     # the NaN row (diverged) is skipped
    got = flops_to_go(rs, goal, r, into)[0]
    L = flop_length(rs)
    assert got[0] == pytest.approx(1 + TIE_BREAK * 0.05 / L)                 # 0.05 + 0.9 = 0.95: in the disc
    away = {face: np.array([[-0.5, 0.0]])}
    assert flops_to_go(rs, goal, r, away)[0, 0] > 1 + (0.95 - r) / L


def test_next_flops_simulates_three_edges_per_landing_face() -> None:
    from physics.parameters import ParameterSpace
    from physics.pool import DaskPool
    from planners import rollouts

    start = RobotStart.settled()
    theta = ParameterSpace.t6().nominal
    with DaskPool(n_workers=0) as pool:
        rs = rollouts([FlopAction(float(face_headings(start.nodes)[0]), 0.3, 4)], start, theta[None], pool=pool)
        nxt = next_flops(rs, pool)
    faces = {tuple(start.face)} | {tuple(o.face) for row in rs.outcomes for o in row if o.ok}
    assert set(nxt) == faces and all(d.shape == (3, 2) for d in nxt.values())
    lengths = np.linalg.norm(np.concatenate(list(nxt.values())), axis=1)
    assert np.all(np.isfinite(lengths)) and np.median(lengths) > 0.2        # real flops, not nudges
