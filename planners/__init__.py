"""planners: decisions made with the belief — robust flop plans over P, and probing actions that
identify faster.

- :mod:`planners.actions`: :class:`FlopAction` and candidate sets;
- :mod:`planners.rollouts`: one flop from a sensed start under many θ, in parallel
  (:class:`RobotStart`, :class:`Outcome`, :func:`rollouts`, :func:`sample_rollouts`);
- :mod:`planners.robot`: the "real" robot of an experiment, a simulation at a hidden θ*;
- :mod:`planners.lookahead`: flops still needed after a flop, the next one predicted from the
  landing face (the two-flop horizon);
- :mod:`planners.robust`: expected value, CVaR_α, probability of success; :func:`plan_flop`,
  :func:`plan_to_goal`, :class:`PointBelief` (nominal and MAP plans);
- :mod:`planners.learning`: P re-weighed by every executed flop (:class:`FlopEvidence`);
- :mod:`planners.probe`: expected information gain of a probe and the active identification loop;
- :mod:`planners.plots`, :mod:`planners.cli` (``tensegrid plan``, ``tensegrid probe``).

planners depends on belief, embeddings and physics; nothing depends on planners.
"""
from __future__ import annotations

from planners.actions import FlopAction, candidate_actions, face_headings
from planners.errors import ActionError, EmptyBeliefError, GoalError, LevelError, PlannerError, RobotMismatchError
from planners.learning import FlopEvidence
from planners.lookahead import flops_to_go
from planners.probe import (
    ProbeRun,
    ProbeStep,
    information_gain,
    probe,
    probe_actions,
    restricted_belief,
    support,
    update_weights,
)
from planners.robot import SimulatedRobot
from planners.robust import (
    RISK_MEASURES,
    FlopChoice,
    GoalRun,
    PlanStep,
    PointBelief,
    cvar,
    outcome_values,
    plan_flop,
    plan_to_goal,
    progress,
    score,
)
from planners.rollouts import Outcome, RobotStart, RolloutSet, check_belief, rollouts, sample_rollouts

__all__ = [
    "FlopAction", "candidate_actions", "face_headings",
    "PlannerError", "ActionError", "GoalError", "EmptyBeliefError", "RobotMismatchError", "LevelError",
    "RobotStart", "Outcome", "RolloutSet", "check_belief", "rollouts", "sample_rollouts", "SimulatedRobot",
    "RISK_MEASURES", "PointBelief", "cvar", "progress", "outcome_values", "flops_to_go", "score", "FlopChoice",
    "plan_flop", "PlanStep", "GoalRun", "plan_to_goal",
    "support", "information_gain", "update_weights", "probe_actions", "restricted_belief", "ProbeStep", "ProbeRun",
    "probe", "FlopEvidence",
]
