"""Hand an identification over to another decoder: the evaluations made in one latent space become
the initial data of Bayesian optimization in another, e.g. a learned 5-D latent box first (a fast
start where the decoder's image is good), then the full 15-D space (which holds the truth).

::

    stage 1   first = search(objective, decoder_a, grid_a, budget=k)
    stage 2   grid_b = SobolCandidates(decoder_b.bounds, n, seed, include=decoder_b.encode(θ_1 .. θ_k))
              carried: cell i <- evaluation i of stage 1 (θ_i, E_i, status, seconds, segment errors), batch 0
              search(objective, decoder_b, grid_b, carry=carried, budget=k + m)

The carried evaluations are stage 2's batch 0: its GP fits them with its own evaluations, they
count in its budget (evaluations and seconds), and no simulation is repeated. Stage 2's decoder
must be an :class:`embeddings.base.EncodingDecoder` that encodes θ exactly, decode(encode(θ)) = θ
(``Identity`` does), or a carried E would belong to another θ than its cell's; :func:`carry_over`
checks it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from belief.errors import BeliefError, BudgetError
from belief.grid import SobolCandidates
from belief.journal import Record
from belief.result import IdentificationResult
from belief.search import search
from embeddings.base import Decoder, EncodingDecoder
from physics.objective import Objective, ObjectiveFunction

__all__ = ["Carried", "carry_over", "continue_in"]


@dataclass(frozen=True)
class Carried:
    """Stage 2's candidate set (the carried θ as cells 0..k-1, then ``n`` Sobol points) and the
    carried evaluations as records of those cells."""

    grid: SobolCandidates
    records: tuple[Record, ...]


def carry_over(previous: IdentificationResult, decoder: Decoder, *, n: int, seed: int, rtol: float = 1e-9) -> Carried:
    """The evaluations of ``previous`` as batch 0 over ``SobolCandidates(decoder.bounds, n, seed)``
    extended by their encoded θ (``k`` evaluations -> ``k + n`` cells)."""
    hist = previous.history
    theta = np.asarray(hist["theta"].values, dtype=float)
    if theta.shape[0] == 0:
        raise BeliefError("the previous identification has no evaluations to carry over.")
    if not isinstance(decoder, EncodingDecoder):
        raise BeliefError(f"{type(decoder).__name__} has no encode(θ) (it is not an embeddings.EncodingDecoder); "
                          "carry evaluations over to a decoder that encodes θ exactly, e.g. embeddings.Identity.")
    z = np.atleast_2d(decoder.encode(theta))
    back = decoder.decode(z)
    scale = decoder.space.upper - decoder.space.lower
    if not np.all(np.abs(back - theta) <= rtol * scale):
        raise BeliefError(f"{type(decoder).__name__} does not decode its encoding of the carried θ back to θ "
                          f"(largest miss {np.max(np.abs(back - theta) / scale):.3g} of the box); carry over to a "
                          "decoder without reduction, e.g. embeddings.Identity.")
    grid = SobolCandidates(decoder.bounds, n=n, seed=seed, include=z)
    parts = np.asarray(hist["parts"].values, dtype=float)
    records = tuple(
        Record(0, k, tuple(float(v) for v in grid.points[k]), tuple(float(v) for v in theta[k]),
               float(hist["error"].values[k]), float(hist["seconds"].values[k]), str(hist["status"].values[k]),
               str(hist["message"].values[k]),
               tuple(float(v) for v in parts[k]) if str(hist["status"].values[k]) == "ok" else ())
        for k in range(theta.shape[0]))
    return Carried(grid, records)


def continue_in(previous: IdentificationResult, objective: Objective | ObjectiveFunction, decoder: Decoder, *,
                budget: int, seed: int, n: int = 4096, **options: Any) -> IdentificationResult:
    """Stage 2 of the module docstring: BO over ``decoder``'s box with the evaluations of ``previous``
    as its initial design; ``budget`` counts them (``budget`` - k new evaluations). ``options`` go to
    :func:`belief.search.search` (journal, q, time_budget, posterior, ...)."""
    carried = carry_over(previous, decoder, n=n, seed=seed)
    if budget <= len(carried.records):
        raise BudgetError(f"budget={budget} leaves no evaluation after the {len(carried.records)} carried over; "
                          "raise it.")
    return search(objective, decoder, carried.grid, budget=budget, seed=seed, carry=carried.records, **options)
