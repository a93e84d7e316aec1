"""Typed errors of the criticism package.

:class:`CriticismError` derives from :class:`belief.errors.BeliefError` (and so from
:class:`physics.errors.TensegridError` and ``ValueError``): a diagnosis runs identifications, and a
caller catches what goes wrong in either with one ``except BeliefError``. Messages name the
argument, what was expected, what was received and how to fix it.
"""
from __future__ import annotations

from belief.errors import BeliefError

__all__ = ["CriticismError"]


class CriticismError(BeliefError):
    """Invalid input to model criticism: masks over segments, held-out indices, configurations, losses."""
