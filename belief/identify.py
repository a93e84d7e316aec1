"""The entry point: identify θ from an objective E(θ), by a named recipe or by one search.

::

    identify(E, budget=60, seed=0)                         the best recipe, DEFAULT_PRESET
    identify(E, budget=60, seed=0, preset="bo")            another recipe (belief.presets)
    identify(E, decoder, budget=60, seed=0, preset="latent")   a recipe with this latent decoder
    identify(E, decoder, grid, budget=60, seed=0)          one search over ``grid`` (belief.search)

Without a grid, ``identify`` runs a preset over the one driver, its stages choosing their own
candidate sets; ``decoder`` is then the latent stage's decoder. With a grid it runs one search of
Algorithm 1 over it with ``decoder``, and ``preset`` must be left out. Every other option goes to
the stages (journal, time_budget, q, n_init, posterior, surrogate, verdict_config, progress, ...;
belief.search.search lists them).
"""
from __future__ import annotations

from typing import Any

from belief.errors import BeliefError, BudgetError
from belief.grid import CandidateSet
from belief.presets import DEFAULT_PRESET, Preset, run_preset
from belief.result import IdentificationResult
from belief.search import search
from embeddings.base import Decoder
from physics.objective import Objective, ObjectiveFunction

__all__ = ["identify"]


def identify(objective: Objective | ObjectiveFunction, decoder: Decoder | None = None,
             grid: CandidateSet | None = None, *, budget: int | None = None, seed: int,
             preset: str | Preset | None = None, **options: Any) -> IdentificationResult:
    """Identify θ by ``preset`` (default :data:`belief.presets.DEFAULT_PRESET`), or by one search
    over ``grid`` with ``decoder`` when a grid is given (module docstring)."""
    if grid is None:
        if budget is None:
            raise BudgetError("a preset needs budget=N evaluations (it splits them between its stages); "
                              "pass budget=, or a decoder and grid for a search bounded by time_budget alone.")
        return run_preset(objective, preset if preset is not None else DEFAULT_PRESET, budget=budget, seed=seed,
                          decoder=decoder, **options)
    if decoder is None:
        raise BeliefError("a grid needs the decoder that maps its cells to θ: identify(objective, decoder, grid, ...); "
                          "or leave out both and name a preset.")
    if preset is not None:
        raise BeliefError(f"preset={preset!r} chooses its own candidate sets; pass either a preset or a grid "
                          "(one search over it), not both.")
    return search(objective, decoder, grid, budget=budget, seed=seed, **options)
