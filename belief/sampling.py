"""What planners need of a belief about θ: :class:`SamplingBelief`, a distribution over n parameter vectors.

A planner scores actions by their outcomes under draws θ ~ P, so it needs the support, its
probabilities and a seeded sampler, nothing of how P was found (grids, decoders, verdicts):

- ``space``: the :class:`~physics.parameters.ParameterSpace` of θ (D parameters);
- ``theta``: the n support points, shape ``(n, D)``;
- ``p``: their probabilities, shape ``(n,)``, >= 0, summing to 1;
- ``sample(k, seed=...)``: k draws of θ, shape ``(k, D)``, rows of ``theta`` drawn with
  probability ``p``; the same seed gives the same draws.

:class:`belief.Belief` implements it (P over the cells of a grid); ``planners.PointBelief`` (all
mass on one θ, e.g. the nominal or the MAP θ) too. Planners that also re-weigh P by new evidence
(planners.learning) take a :class:`belief.Belief`.
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from physics.parameters import ParameterSpace

__all__ = ["SamplingBelief"]


@runtime_checkable
class SamplingBelief(Protocol):
    """Structural type of a distribution over θ (module docstring): support ``theta`` (n, D) with
    probabilities ``p`` (n,) in ``space``, and seeded draws ``sample(k, seed=...)`` (k, D)."""

    space: ParameterSpace
    theta: np.ndarray

    @property
    def p(self) -> np.ndarray:
        """Probabilities of the rows of ``theta``, shape (n,), summing to 1."""
        ...

    def sample(self, n: int, *, seed: int | np.random.Generator) -> np.ndarray:
        """n draws of θ, shape (n, D), a function of ``seed``."""
        ...
