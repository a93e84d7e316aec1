"""Proposers: which cells to evaluate next, given the history (steps 1 and 3-4 of Algorithm 1).

A proposer implements the :class:`Proposer` protocol:

- ``propose(batch, history, size, grid) -> Proposal``: the ``size`` cells of batch ``batch``
  (never one already in ``history``), a deterministic function of its own seed and ``history``
  (the journal's replay depends on it);
- ``config() -> dict``: JSON-able options, part of the problem's fingerprint.

The identification driver (belief.driver) owns budgets, journal and evaluation; a new strategy
(active probing, another surrogate) is a new proposer, not an edit of the driver.

- :class:`RandomProposer`: a seeded permutation of the cells (random search);
- :class:`SobolDesign`: scrambled Sobol points of the latent box snapped to their nearest cells
  (the initial design of BO; alone, quasi-random search);
- :class:`WarmStart`: given cells first (e.g. the previous estimate), then another proposer;
- :class:`BOProposer`: an initial design (``SobolDesign`` by default) at batch 0, then the GP
  surrogate (belief.surrogate) and an acquisition over the unevaluated cells (log expected
  improvement with a kriging-believer batch, belief.acquisition.select_cells).

Batch sizes (``n_init`` for batch 0, ``q`` after) are the driver's budget, not a proposer option:
every proposer fills the batch it is given.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from scipy.stats import qmc

from belief.acquisition import select_cells
from belief.grid import CandidateSet
from belief.journal import Record
from belief.surrogate import GPSurrogate, SurrogateConfig

__all__ = ["Proposal", "Proposer", "RandomProposer", "SobolDesign", "WarmStart", "BOProposer", "Acquisition",
           "sobol_design", "fit_surrogate"]

class Acquisition(Protocol):
    """Which q cells to evaluate next: ``(model, points (n x d), available (n,) bool, *, q, prediction)``
    -> q indices of available cells; ``prediction`` is the model's (mean, var) (n,) at ``points``.
    belief.acquisition.select_cells (log EI, kriging believer) is the default."""

    def __call__(self, surrogate: GPSurrogate, points: np.ndarray, available: np.ndarray, *, q: int,
                 prediction: tuple[np.ndarray, np.ndarray] | None) -> list[int]: ...


@dataclass(frozen=True)
class Proposal:
    """Cells to evaluate (grid indices) and, for model-based proposers, the fitted surrogate and its
    prediction (mean, var) over every cell, which the driver may reuse (e.g. for P after a batch)."""

    cells: list[int]
    model: GPSurrogate | None = None
    prediction: tuple[np.ndarray, np.ndarray] | None = None


@runtime_checkable
class Proposer(Protocol):
    """The proposer contract (module docstring)."""

    def propose(self, batch: int, history: Sequence[Record], size: int, grid: CandidateSet) -> Proposal:
        """The ``size`` cells of batch ``batch``, none in ``history``; a function of the seed and ``history``."""
        ...

    def config(self) -> dict[str, Any]:
        """JSON-able options (kind, seed, ...), part of the problem's fingerprint."""
        ...


def sobol_design(grid: CandidateSet, n: int, seed: int) -> list[int]:
    """n distinct cells nearest to scrambled Sobol points of the latent box (filled from a seeded permutation)."""
    n = min(n, grid.size)
    sob = qmc.Sobol(grid.dim, scramble=True, seed=seed)
    pts = qmc.scale(sob.random(int(2 ** math.ceil(math.log2(max(n, 1))))), grid.bounds[:, 0], grid.bounds[:, 1])
    cells: list[int] = []
    for c in list(grid.nearest(pts)) + list(np.random.default_rng([seed, 3]).permutation(grid.size)):
        if len(cells) == n:
            break
        if int(c) not in cells:
            cells.append(int(c))
    return cells


def fit_surrogate(history: Sequence[Record], grid: CandidateSet, config: SurrogateConfig) -> GPSurrogate | None:
    """The GP fitted to the successful evaluations (failed ones at the worst error with
    ``config.impute_failed``); None with fewer than 2 data."""
    ok = [r for r in history if r.status == "ok"]
    Z = [r.z for r in ok]
    E = [r.error for r in ok]
    if config.impute_failed and ok:
        bad = [r for r in history if r.status != "ok"]
        Z += [r.z for r in bad]
        E += [max(r.error for r in ok)] * len(bad)
    if len(Z) < 2:
        return None
    return GPSurrogate(grid.bounds, config=config).fit(np.asarray(Z), np.asarray(E))


def _unevaluated(order: np.ndarray, history: Sequence[Record], size: int) -> list[int]:
    evaluated = {r.cell for r in history}
    return [int(c) for c in order if int(c) not in evaluated][:size]


class RandomProposer:
    """Random search: the cells of a permutation drawn from ``seed``, in order, skipping evaluated ones."""

    def __init__(self, seed: int) -> None:
        self.seed = int(seed)

    def propose(self, batch: int, history: Sequence[Record], size: int, grid: CandidateSet) -> Proposal:
        return Proposal(_unevaluated(np.random.default_rng([self.seed, 1]).permutation(grid.size), history, size))

    def config(self) -> dict[str, Any]:
        return {"kind": "random", "seed": self.seed}


class SobolDesign:
    """Quasi-random design: the cells nearest to the scrambled Sobol sequence drawn from ``seed``, in
    order, skipping evaluated ones. At batch 0 of ``size`` cells it is :func:`sobol_design`."""

    def __init__(self, seed: int) -> None:
        self.seed = int(seed)

    def propose(self, batch: int, history: Sequence[Record], size: int, grid: CandidateSet) -> Proposal:
        order = sobol_design(grid, len(history) + size, self.seed)
        return Proposal(_unevaluated(np.asarray(order), history, size))

    def config(self) -> dict[str, Any]:
        return {"kind": "sobol", "seed": self.seed}


class WarmStart:
    """The cells ``cells`` first (those not yet evaluated), then ``then``'s proposals: an initial
    design that starts from known good points, e.g. ``BOProposer(seed, initial=WarmStart([0], SobolDesign(seed)))``."""

    def __init__(self, cells: Sequence[int], then: Proposer) -> None:
        self.cells, self.then = [int(c) for c in cells], then

    def propose(self, batch: int, history: Sequence[Record], size: int, grid: CandidateSet) -> Proposal:
        first = _unevaluated(np.asarray(self.cells), history, size)
        if len(first) == size:
            return Proposal(first)
        rest = self.then.propose(batch, history, size, grid).cells
        rest = [c for c in rest if c not in first]
        if len(first) + len(rest) < size:   # ``then`` proposed some of the warm cells: ask for a few more
            extra = self.then.propose(batch, history, size + len(first), grid).cells
            rest += [c for c in extra if c not in first and c not in rest]
        return Proposal((first + rest)[:size])

    def config(self) -> dict[str, Any]:
        return {"kind": "warm", "cells": self.cells, "then": self.then.config()}


def _callable_name(fn: Acquisition) -> str:
    """``module.qualname`` of an acquisition function (or of its class, for a callable object)."""
    named = fn if hasattr(fn, "__qualname__") else type(fn)
    return f"{named.__module__}.{named.__qualname__}"


class BOProposer:
    """Bayesian optimization (steps 1, 3-4 of Algorithm 1): ``initial`` (default ``SobolDesign(seed)``)
    proposes batch 0; later batches fit the GP to the history and take the cells chosen by
    ``acquisition`` (default: log EI, kriging believer for batches of q > 1) among unevaluated ones;
    with fewer than 2 successes, the next cells of a seeded permutation."""

    def __init__(self, seed: int, *, surrogate: SurrogateConfig | None = None,
                 acquisition: Acquisition = select_cells, initial: Proposer | None = None) -> None:
        self.seed = int(seed)
        self.surrogate = surrogate or SurrogateConfig()
        self.acquisition = acquisition
        self.initial = initial if initial is not None else SobolDesign(self.seed)

    def propose(self, batch: int, history: Sequence[Record], size: int, grid: CandidateSet) -> Proposal:
        if batch == 0:
            return self.initial.propose(batch, history, size, grid)
        model = fit_surrogate(history, grid, self.surrogate)
        if model is None:
            order = np.random.default_rng([self.seed, 4, batch]).permutation(grid.size)
            return Proposal(_unevaluated(order, history, size))
        avail = np.ones(grid.size, dtype=bool)
        avail[[r.cell for r in history]] = False
        pred = model.predict(grid.points)
        return Proposal(self.acquisition(model, grid.points, avail, q=size, prediction=pred), model, pred)

    def config(self) -> dict[str, Any]:
        return {"kind": "bo", "seed": self.seed, "acquisition": _callable_name(self.acquisition),
                "initial": self.initial.config(),
                "surrogate": {k: getattr(self.surrogate, k) for k in self.surrogate.__dataclass_fields__}}
