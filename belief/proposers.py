"""Proposers: which cells to evaluate next, given the history (steps 1 and 3-4 of Algorithm 1).

A proposer is any object with

- ``propose(batch, history, size, grid) -> Proposal``: the ``size`` cells of batch ``batch``
  (never one already in ``history``), a deterministic function of its own seed and ``history``
  (the journal's replay depends on it);
- ``config() -> dict``: JSON-able options, part of the problem's fingerprint.

The identification driver (belief.driver) owns budgets, journal and evaluation; a new strategy
(active probing, another surrogate) is a new proposer, not an edit of the driver.

- :class:`RandomProposer`: a seeded permutation of the cells (random search);
- :class:`BOProposer`: an initial design of scrambled Sobol points snapped to cells, then the GP
  surrogate (belief.surrogate) and log expected improvement with a kriging-believer batch
  (belief.acquisition) over the unevaluated cells.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol, Sequence, runtime_checkable

import numpy as np
from scipy.stats import qmc

from belief.acquisition import select_cells
from belief.journal import Record
from belief.surrogate import GPSurrogate, SurrogateConfig

__all__ = ["Proposal", "Proposer", "RandomProposer", "BOProposer", "sobol_design", "fit_surrogate"]


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

    def propose(self, batch: int, history: Sequence[Record], size: int, grid: Any) -> Proposal: ...

    def config(self) -> dict[str, Any]: ...


def sobol_design(grid: Any, n: int, seed: int) -> list[int]:
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


def fit_surrogate(history: Sequence[Record], grid: Any, config: SurrogateConfig, *,
                  impute_failed: bool = False) -> GPSurrogate | None:
    """The GP fitted to the successful evaluations (failed ones at the worst error with
    ``impute_failed``); None with fewer than 2 data."""
    ok = [r for r in history if r.status == "ok"]
    Z = [r.z for r in ok]
    E = [r.error for r in ok]
    if impute_failed and ok:
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

    def propose(self, batch: int, history: Sequence[Record], size: int, grid: Any) -> Proposal:
        return Proposal(_unevaluated(np.random.default_rng([self.seed, 1]).permutation(grid.size), history, size))

    def config(self) -> dict[str, Any]:
        return {"kind": "random", "seed": self.seed}


class BOProposer:
    """Bayesian optimization: Sobol design at batch 0, then log EI under the GP (kriging believer
    for batches of q > 1); with fewer than 2 successes, the next cells of a seeded permutation."""

    def __init__(self, seed: int, *, surrogate: SurrogateConfig | None = None, impute_failed: bool = False) -> None:
        self.seed = int(seed)
        self.surrogate = surrogate or SurrogateConfig()
        self.impute_failed = bool(impute_failed)

    def propose(self, batch: int, history: Sequence[Record], size: int, grid: Any) -> Proposal:
        if batch == 0:
            return Proposal(sobol_design(grid, size, self.seed))
        model = fit_surrogate(history, grid, self.surrogate, impute_failed=self.impute_failed)
        if model is None:
            order = np.random.default_rng([self.seed, 4, batch]).permutation(grid.size)
            return Proposal(_unevaluated(order, history, size))
        avail = np.ones(grid.size, dtype=bool)
        avail[[r.cell for r in history]] = False
        pred = model.predict(grid.points)
        return Proposal(select_cells(model, grid.points, avail, q=size, prediction=pred), model, pred)

    def config(self) -> dict[str, Any]:
        return {"kind": "bo", "seed": self.seed, "impute_failed": self.impute_failed,
                "surrogate": {k: getattr(self.surrogate, k) for k in self.surrogate.__dataclass_fields__}}
