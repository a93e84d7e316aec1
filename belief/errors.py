"""Typed errors of the belief package.

All derive from :class:`physics.errors.TensegridError`; those caused by a bad argument also
derive from ``ValueError``. Messages name the argument, what was expected, what was received and
how to fix it.
"""
from __future__ import annotations

from physics.errors import TensegridError

__all__ = ["BeliefError", "GridError", "BudgetError", "ObjectiveError", "JournalError", "SurrogateError",
           "BudgetWarning"]


class BeliefError(TensegridError, ValueError):
    """Invalid input to the belief package (shapes, options, data)."""


class GridError(BeliefError):
    """A grid or candidate set is empty, too large, or has invalid bounds."""


class BudgetError(BeliefError):
    """The evaluation or time budget is zero, negative or inconsistent with the initial design."""


class ObjectiveError(BeliefError):
    """The objective returned something that is not a scalar error, or every evaluation failed."""


class JournalError(TensegridError, ValueError):
    """A journal file belongs to another problem, or is corrupt."""


class SurrogateError(TensegridError, RuntimeError):
    """The Gaussian-process surrogate could not be fitted (e.g. Cholesky failed at the largest jitter)."""


class BudgetWarning(UserWarning):
    """The evaluation budget is too small for the search dimension to map E; P is partial."""
