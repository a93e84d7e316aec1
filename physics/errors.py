"""Typed errors of tensegrid.

Every error derives from :class:`TensegridError` and, where it fits, from the matching built-in
(``ParameterError`` is a ``ValueError``) so callers can catch either. Messages name the argument,
what was expected, what was received and how to fix it.
"""
from __future__ import annotations

__all__ = [
    "TensegridError",
    "ParameterError",
    "MeasurementError",
    "TrajectoryFormatError",
    "PhysicsError",
    "ControllerError",
    "PoolError",
    "ContractError",
    "NoResidualsError",
    "TimestampError",
    "StepSizeError",
    "ImportFormatError",
    "OutputError",
]


class TensegridError(Exception):
    """Base class of every error raised by tensegrid."""


class ParameterError(TensegridError, ValueError):
    """A parameter vector or parameter space is invalid (NaN, wrong length, out of bounds...)."""


class MeasurementError(ParameterError):
    """What the user knows about θ cannot be used as given (physics.measurements): a measurement or a
    fixed value that is malformed, names an unknown quantity, is non-physical, is given twice, or lies
    outside what the prior box allows (a unit slip when far outside)."""


class TrajectoryFormatError(TensegridError, ValueError):
    """A trajectory dataset or file does not follow the format of docs/data-format.md."""


class PhysicsError(TensegridError, RuntimeError):
    """A simulation diverged or reached a non-physical state (NaN, exploding speed, negative rest length)."""


class ControllerError(TensegridError, ValueError):
    """A controller was given an invalid option or produced an invalid command."""


class PoolError(TensegridError, RuntimeError):
    """A pool of worker processes could not be started or reached (physics.pool)."""


class ContractError(TensegridError, TypeError):
    """An implementation of a contract (an objective, a decoder, ...) returned or lacks something the
    contract requires: a bug in that implementation, raised at once, never recorded as a status."""


class NoResidualsError(TensegridError, NotImplementedError):
    """The objective gives E(θ) but no residual vectors (a plain function θ -> E): what needs them
    (the "ess" noise rule, least-squares steps, model criticism) falls back or is skipped."""


class TimestampError(TrajectoryFormatError):
    """A trajectory's timestamps do not fit a regular clock: a timestamp further from its tick than
    physics.trajectory.TIMESTAMP_TOLERANCE of the sample interval, or more ticks missing than present."""


class StepSizeError(ParameterError, TrajectoryFormatError):
    """A physics step dt that is not a positive step of at most 0.01 s or does not divide a trajectory's
    sample interval Δ (Δ / dt must be a whole number of steps; physics.predictor.physics_step picks one)."""


class ImportFormatError(TrajectoryFormatError):
    """A file to convert into a trajectory (physics.importers: CSV) lacks the declared layout: a missing
    column, a cell that is not a number, an unknown unit or up axis."""


class OutputError(TensegridError, ValueError):
    """An output path cannot be used: empty, an existing file where a folder is needed, or not writable."""
