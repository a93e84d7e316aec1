"""Typed errors of the planners package.

All derive from :class:`physics.errors.TensegridError` and from ``ValueError`` (every one is caused
by a bad argument). Messages name the argument, what was expected, what was received and what to do.
"""
from __future__ import annotations

from physics.errors import TensegridError

__all__ = ["PlannerError", "ActionError", "GoalError", "EmptyBeliefError", "RobotMismatchError", "LevelError"]


class PlannerError(TensegridError, ValueError):
    """Invalid input to the planners package (options, shapes, seeds)."""


class ActionError(PlannerError):
    """A flop action or a candidate set is invalid (timing, change, cables, empty set)."""


class GoalError(PlannerError):
    """The goal point is not finite, not a point in the plane, too far away or already reached."""


class EmptyBeliefError(PlannerError):
    """The belief has no cells or no probability mass, or zero samples were asked of it."""


class RobotMismatchError(PlannerError):
    """The belief's parameter space is not the one of the robot being planned for (names or dimension)."""


class LevelError(PlannerError):
    """The CVaR level α is not a number in (0, 1]."""
