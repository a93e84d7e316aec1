"""One search: Algorithm 1 of Zhu et al. 2018, Bayesian optimization of E(θ) over a discretized
latent grid, returning a distribution P over the grid instead of a point. The presets
(belief.presets) chain searches; :func:`belief.identify` runs a preset or one search.

::

    input: objective E, decoder z -> θ, grid of latent cells, budget (evaluations and/or seconds), seed
    1  evaluate E at an initial design of n_init cells (scrambled Sobol points of the latent box,
       snapped to their nearest cells; ``method="random"``: a seeded random permutation of cells)
    2  repeat until the budget is spent:
    3      fit the GP surrogate to the successful evaluations              (belief.surrogate)
    4      choose q unevaluated cells maximizing log EI (kriging believer)  (belief.acquisition)
    5      evaluate E at θ = decoder(z) of each chosen cell, journal each   (belief.journal)
    6      update P from the GP (only when a ``callback`` wants it: it costs a pass over the grid)
    7  fit the GP to all evaluations; assess it into a Belief (σ² from the residuals, P,
       segment posteriors, verdicts: belief.assess); return it with the history and the best θ

Steps 1 and 3-4 are a *proposer* (belief.proposers: ``method="bo"`` is :class:`BOProposer`,
``method="random"`` :class:`RandomProposer`, or pass ``proposer=``); budgets, journal and
evaluation are the driver's (belief.driver).

``method="random"`` replaces steps 3-4 by the next cells of the permutation (random search
baseline; with the ``Identity`` decoder on ``SobolCandidates`` it is random search in the full
space). BO in the full space is ``method="bo"`` with the same decoder and candidates.

A plain function θ -> E is wrapped once in :class:`physics.objective.FunctionObjective`
(:func:`physics.objective.as_objective`); everything after that sees the Objective contract.

Failed evaluations (the objective raised :class:`physics.errors.PhysicsError`: status "diverged";
raised another tensegrid error or returned NaN/inf: "failed") are journalled with error NaN, never
proposed again, and left out of the GP fit (``impute_failed=True`` instead gives them the worst
observed error, which pushes the search away from them). Their cells get P = 0.

Determinism: every batch is a function of the seed and the history before it (the GP fit starts
from fixed values and runs single-threaded, ties break to the lowest cell index), so a journalled
run that is killed and resumed ends with exactly the history (cells, z, θ, E, status) of an
uninterrupted run (wall-clock ``seconds`` differ, and so can a ``time_budget`` stop). Each
evaluation is journalled as soon as it finishes, also inside a parallel batch when
``objective.evaluate_batch`` takes ``on_result`` (physics.TrajectoryObjective does): a kill mid-batch
loses only the evaluations still running, and the resumed run evaluates just the batch's missing
cells. The returned history is ordered by batch, then cell index, because a parallel batch
finishes in any order.

Time budget: counts the journalled seconds of replayed evaluations plus this session's wall time;
it is checked before each batch.

Why not botorch/Ax: the project uses pyro.contrib.gp for the GP (DESIGN.md), and the loop is over
a finite set of cells, which needs no continuous acquisition optimizer.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable, Sequence
from typing import Any, Literal

import numpy as np
import xarray as xr

from belief.assess import assess
from belief.driver import Budget, DriverResult, run
from belief.errors import BeliefError, BudgetError, GridError, ObjectiveError
from belief.grid import CandidateSet
from belief.journal import Journal, Record
from belief.posterior import PosteriorConfig, posterior_from_surrogate
from belief.proposers import BOProposer, Proposal, Proposer, RandomProposer, fit_surrogate
from belief.result import IdentificationResult, history_dataset
from belief.surrogate import SurrogateConfig
from belief.verdicts import VerdictConfig
from embeddings.base import Decoder
from physics.objective import Objective, ObjectiveFunction, as_objective
from physics.parameters import ParameterSpace

__all__ = ["search", "problem_fingerprint"]

_METHODS = ("bo", "random")


def _space_config(space: ParameterSpace) -> dict[str, Any]:
    return {"names": list(space.names), "units": list(space.units),
            "lower": [float(v) for v in space.lower], "upper": [float(v) for v in space.upper]}


def problem_fingerprint(
    objective: Objective, decoder: Decoder, grid: CandidateSet, *, space: ParameterSpace, seed: int, method: str,
    q: int, n_init: int, surrogate: SurrogateConfig, impute_failed: bool, proposer: Proposer | None = None,
) -> dict[str, Any]:
    """The JSON-able identity of an identification problem, stored in and checked against a journal."""
    fp: dict[str, Any] = {
        "space": _space_config(space), "decoder": decoder.config(), "grid": grid.config(), "seed": int(seed),
        "method": method, "q": int(q), "n_init": int(n_init), "impute_failed": bool(impute_failed),
        "surrogate": {k: getattr(surrogate, k) for k in surrogate.__dataclass_fields__},
    }
    if proposer is not None:
        fp["proposer"] = proposer.config()
    fp["objective"] = objective.fingerprint()
    return fp


def _validate_problem(objective: Objective | ObjectiveFunction, decoder: Decoder, grid: CandidateSet,
                      space: ParameterSpace | None, workers: int) -> tuple[Objective, ParameterSpace]:
    """The objective (a plain function wrapped once, on ``workers`` threads) and its parameter space,
    after checking that objective, decoder and grid fit together."""
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise BeliefError(f"workers must be an integer >= 1, got {workers!r}.")
    objective = as_objective(objective, space, workers=int(workers))
    space = objective.space
    if not isinstance(decoder, Decoder):
        raise BeliefError(f"decoder must be an embeddings.Decoder (.space, .dim, .bounds, .decode(z)), got "
                          f"{type(decoder).__name__}.")
    dspace = decoder.space
    if not dspace.same_box(space):
        raise BeliefError(
            f"decoder's parameter space {list(dspace.names)} (bounds) differs from the objective's "
            f"{list(space.names)}; build the decoder on objective.space."
        )
    if not isinstance(grid, CandidateSet):
        raise GridError(f"grid must be a belief.grid.CandidateSet (belief.Grid or belief.SobolCandidates), got "
                        f"{type(grid).__name__}.")
    if grid.size < 1:
        raise GridError("grid is empty (0 cells); give points_per_dim >= 2 or n >= 1.")
    if grid.dim != decoder.dim:
        raise GridError(
            f"grid has {grid.dim} latent dimensions but the decoder has {decoder.dim}; build the grid with "
            "Grid.for_decoder(decoder, ...)."
        )
    lo, hi = decoder.bounds[:, 0], decoder.bounds[:, 1]
    tol = 1e-9 * (hi - lo)
    if np.any(grid.bounds[:, 0] < lo - tol) or np.any(grid.bounds[:, 1] > hi + tol):
        raise GridError(f"grid bounds {grid.bounds.tolist()} leave the decoder's latent box {decoder.bounds.tolist()}.")
    return objective, space


def _validate_budget(grid: CandidateSet, decoder: Decoder, budget: Any, time_budget: Any, method: str, q: Any,
                     n_init: Any, seed: Any) -> tuple[int, int]:
    """(evaluations to reach, initial design size), after checking budgets and options."""
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool):
        raise BeliefError(f"seed must be an integer, got {seed!r}.")
    if budget is None and time_budget is None:
        raise BudgetError("give budget=N evaluations and/or time_budget=seconds; both are None.")
    if budget is not None:
        if not isinstance(budget, (int, np.integer)) or isinstance(budget, bool):
            raise BudgetError(f"budget must be an integer number of evaluations, got {budget!r}.")
        if budget < 1:
            raise BudgetError(f"budget must be >= 1 evaluation, got {budget!r}; a zero budget identifies nothing.")
        if budget > grid.size:
            raise BudgetError(
                f"budget={budget} exceeds the {grid.size} grid cells (each cell is evaluated at most once); "
                "use a finer grid or a smaller budget."
            )
    if time_budget is not None and not (isinstance(time_budget, (int, float)) and math.isfinite(time_budget)
                                        and time_budget > 0):
        raise BudgetError(f"time_budget must be a positive number of seconds, got {time_budget!r}.")
    if method not in _METHODS:
        raise BeliefError(f"method must be one of {_METHODS}, got {method!r}.")
    if not isinstance(q, (int, np.integer)) or q < 1:
        raise BudgetError(f"q (cells per batch) must be an integer >= 1, got {q!r}.")
    n_target = int(budget) if budget is not None else int(grid.size)
    if n_init is None:
        n_init = max(5, decoder.dim + 1)
    if not isinstance(n_init, (int, np.integer)) or n_init < 1:
        raise BudgetError(f"n_init must be an integer >= 1, got {n_init!r}.")
    if method == "bo" and n_init < 2:
        raise BudgetError(f"method='bo' needs n_init >= 2 initial evaluations to fit the GP, got {n_init}.")
    return n_target, int(n_init)


def _carried_init(carry: Sequence[Record], n_init: Any) -> Any:
    """The initial design size with carried evaluations: their number (they are batch 0)."""
    if not carry:
        return n_init
    if any(not isinstance(r, Record) or r.batch != 0 for r in carry):
        raise BeliefError("carry must be belief.Record rows of batch 0 (build them with belief.handoff.carry_over).")
    if n_init is not None and n_init != len(carry):
        raise BudgetError(f"n_init={n_init} contradicts the {len(carry)} carried evaluations, which are the initial "
                          "design; leave n_init unset.")
    return len(carry)


def _carried_fingerprint(carry: Sequence[Record]) -> dict[str, Any]:
    """Number and SHA-256 of the carried (cell, E, status): a journal refuses other carried data."""
    text = json.dumps([[r.cell, repr(r.error), r.status] for r in carry])
    return {"n": len(carry), "sha256": hashlib.sha256(text.encode()).hexdigest()}


def _posterior_config(posterior: Literal["likelihood", "minimizer"] | None, posterior_config: PosteriorConfig | None,
                      noise_var: float | None) -> PosteriorConfig:
    if posterior is not None and posterior_config is not None and posterior_config.mode != posterior:
        raise BeliefError(
            f"posterior={posterior!r} contradicts posterior_config.mode={posterior_config.mode!r}; give one of them."
        )
    pcfg = posterior_config or PosteriorConfig(mode=posterior or "likelihood", noise_var=noise_var)
    if noise_var is not None and pcfg.noise_var is None:
        pcfg = PosteriorConfig(**{**pcfg.__dict__, "noise_var": noise_var})
    return pcfg


def _callback_hook(callback: Callable[[int, xr.DataArray], None] | None, objective: Objective, grid: CandidateSet,
                   pcfg: PosteriorConfig, seed: int) -> Callable[[int, Sequence[Record], Proposal], None] | None:
    """after_batch hook of the driver that reports P (σ² by the iid rule or the known noise) before each batch."""
    if callback is None:
        return None
    from belief.noise import iid_noise_var

    def hook(n_before: int, hist: Sequence[Record], proposal: Proposal) -> None:
        if proposal.model is None:
            return
        ok = np.array([r.error for r in hist if r.status == "ok"])
        nv = pcfg.noise_var or objective.noise_var
        known = nv is not None
        if pcfg.mode == "likelihood" and nv is None:
            nv = iid_noise_var(ok, n_observations=objective.n_observations, dim=grid.dim)
        failed = np.zeros(grid.size, dtype=bool)
        failed[[r.cell for r in hist if r.status != "ok"]] = True
        callback(n_before, posterior_from_surrogate(proposal.model, grid, config=pcfg, noise_var=nv, failed=failed,
                                                    seed=seed, prediction=proposal.prediction, noise_known=known))

    return hook


def search(
    objective: Objective | ObjectiveFunction,
    decoder: Decoder,
    grid: CandidateSet,
    *,
    budget: int | None = None,
    seed: int,
    journal: str | os.PathLike[str] | None = None,
    time_budget: float | None = None,
    method: Literal["bo", "random"] = "bo",
    proposer: Proposer | None = None,
    q: int = 1,
    n_init: int | None = None,
    posterior: Literal["likelihood", "minimizer"] | None = "likelihood",
    noise_var: float | None = None,
    space: ParameterSpace | None = None,
    surrogate: SurrogateConfig | None = None,
    posterior_config: PosteriorConfig | None = None,
    verdict_config: VerdictConfig | None = None,
    workers: int = 1,
    impute_failed: bool = False,
    progress: bool = True,
    callback: Callable[[int, xr.DataArray], None] | None = None,
    carry: Sequence[Record] = (),
) -> IdentificationResult:
    """Search ``grid`` by Algorithm 1 (module docstring) and return the belief over it.

    ``objective``: a physics.objective.Objective, or a plain function θ (shape ``D``) -> E (float)
    on ``space`` (wrapped in FunctionObjective, batches on ``workers`` threads); ``decoder``: an
    ``embeddings.Decoder``; ``grid``: a belief.grid.CandidateSet (``belief.Grid`` or
    ``belief.SobolCandidates``) over ``decoder.bounds``. ``budget``: evaluations; ``time_budget``:
    seconds (either or both); ``seed``: all randomness; ``journal``: SQLite path,
    resumed if it exists; ``method``: built-in proposer, or ``proposer=`` any belief.proposers.Proposer;
    ``q``: cells per batch; ``n_init``: initial design size (default max(5, d + 1)); ``posterior``:
    mode of P, or None to skip it; ``noise_var``: σ² of the likelihood mode (default: the
    objective's, else ``posterior_config.noise_rule``); ``verdict_config``: thresholds of the
    verdicts (belief.verdicts; ``refit=False`` skips the local Gauss-Newton check);
    ``callback(n_evaluations, P)``: called
    before every batch with a fitted surrogate (one extra pass over the grid per batch); ``carry``:
    evaluations made before this run, as batch 0 (belief.handoff builds them; ``n_init`` is their number).
    """
    objective, space = _validate_problem(objective, decoder, grid, space, workers)
    n_init = _carried_init(carry, n_init)
    n_target, n_init = _validate_budget(grid, decoder, budget, time_budget, method, q, n_init, seed)
    seed, scfg = int(seed), surrogate or SurrogateConfig()
    pcfg = _posterior_config(posterior, posterior_config, noise_var)
    custom = proposer is not None
    if proposer is None:
        proposer = (RandomProposer(seed) if method == "random"
                    else BOProposer(seed, surrogate=scfg, impute_failed=impute_failed))
    fp = problem_fingerprint(objective, decoder, grid, space=space, seed=seed, method=method, q=int(q), n_init=n_init,
                             surrogate=scfg, impute_failed=impute_failed, proposer=proposer if custom else None)
    if carry:
        fp["carried"] = _carried_fingerprint(carry)
    jr = Journal(journal, fp) if journal is not None else None
    try:
        out = run(objective, decoder, grid, proposer, Budget(n_target, time_budget, n_init, int(q)), journal=jr,
                  progress=progress, label=f"identify[{method}]",
                  after_batch=_callback_hook(callback if posterior is not None else None, objective, grid, pcfg, seed),
                  carried=tuple(carry))
    finally:
        if jr is not None:
            jr.close()
    return _result(objective, decoder, grid, out, space=space, config=fp, pcfg=pcfg if posterior else None,
                   scfg=scfg, impute_failed=impute_failed, seed=seed, vcfg=verdict_config,
                   extra={"budget": budget, "time_budget": time_budget})


def _result(objective: Objective, decoder: Decoder, grid: CandidateSet, out: DriverResult, *, space: ParameterSpace,
            config: dict[str, Any], pcfg: PosteriorConfig | None, scfg: SurrogateConfig, impute_failed: bool,
            seed: int, extra: dict[str, Any], vcfg: VerdictConfig | None = None) -> IdentificationResult:
    """The IdentificationResult of the driver's records: best θ, history and (with ``pcfg``) the Belief."""
    records = out.records
    ok = [r for r in records if r.status == "ok"]
    if not records:
        raise BudgetError(f"time_budget={extra.get('time_budget')!r} s was spent before the first evaluation; "
                          "raise it.")
    if not ok:
        raise ObjectiveError(
            f"all {len(records)} evaluations failed (first: {records[0].message}); the parameter box may be "
            "non-physical for this simulator, or the objective is broken."
        )
    best = min(ok, key=lambda r: r.error)
    best_theta = xr.DataArray(np.asarray(best.theta), dims=("parameter",), name="best_theta",
                              coords={"parameter": list(space.names), "unit": ("parameter", list(space.units))})
    belief = None
    if pcfg is not None:
        model = fit_surrogate(records, grid, scfg, impute_failed=impute_failed)
        if model is None:
            raise ObjectiveError(f"only {len(ok)} successful evaluation(s); the posterior needs at least 2.")
        belief = assess(objective, decoder, grid, records, model, config=pcfg, surrogate=scfg, seed=seed,
                        verdict_config=vcfg)
    segments = tuple(objective.segments)
    hist = history_dataset(records, latent_names=tuple(f"z{i}" for i in range(grid.dim)), space=space,
                           segments=segments)
    cfg = dict(config)
    cfg.update(extra)
    cfg.update({"posterior": pcfg.mode if pcfg else None, "stopped": out.stopped, "n_evaluations": len(records),
                "noise_var": None if belief is None else belief.attrs.get("noise_var"),
                "noise_rule": None if belief is None else belief.attrs.get("noise_rule")})
    return IdentificationResult(belief=belief, history=hist, best_theta=best_theta, best_error=float(best.error),
                                config=cfg)
