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

Steps 1 and 3-4 are a *proposer* (belief.proposers: ``proposer="bo"`` is :class:`BOProposer`,
``proposer="random"`` :class:`RandomProposer`, or any :class:`Proposer`); budgets, journal and
evaluation are the driver's (belief.driver).

``proposer="random"`` replaces steps 3-4 by the next cells of the permutation (random search
baseline; with the ``Identity`` decoder on ``SobolCandidates`` it is random search in the full
space). BO in the full space is ``proposer="bo"`` with the same decoder and candidates.

Options come grouped, one source each: how cells are chosen (``proposer``), how the GP is fitted
(:class:`~belief.surrogate.SurrogateConfig`, also whether failures are imputed), what P is
(``posterior``: a mode name or a :class:`~belief.posterior.PosteriorConfig` with σ² and the noise
rule, or None for no P) and what the verdicts demand (:class:`~belief.verdicts.VerdictConfig`);
each validates itself. The parameter space is the objective's; a plain function θ -> E is wrapped
once on the decoder's space (:func:`physics.objective.as_objective`; wrap it yourself in
:class:`~physics.objective.FunctionObjective` to evaluate batches on threads).

Failed evaluations (the objective raised :class:`physics.errors.PhysicsError`: status "diverged";
raised another tensegrid error or returned NaN/inf: "failed") are journalled with error NaN, never
proposed again, and left out of the GP fit (``SurrogateConfig(impute_failed=True)`` instead gives
them the worst observed error, which pushes the search away from them). Their cells get P = 0.

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

Evaluations: ``budget`` counts the search's evaluations of E (``result.n_evaluations``; carried
and replayed ones included). The assessment evaluates E after them (σ² residuals, the local
refit's Gauss-Newton step: belief.assess). With ``budget_counts="all"`` or a ``finish_step`` (the
presets' finishing Gauss-Newton step, taken in the assessment so that it shares those
evaluations) the budget counts them too: the search stops :func:`belief.assess.finishing_cost`
short of it, the most the assessment spends, so a run makes at most ``budget`` evaluations.
``config["evaluations"]`` records the search's, those after it and their total.

Why not botorch/Ax: the project uses pyro.contrib.gp for the GP (DESIGN.md), and the loop is over
a finite set of cells, which needs no continuous acquisition optimizer.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any, Literal

import numpy as np
import xarray as xr

from belief.assess import assess, finishing_cost, fits_to_convergence, step_record
from belief.counting import CountingObjective
from belief.driver import Budget, DriverResult, run
from belief.errors import BeliefError, BudgetError, BudgetWarning, GridError, ObjectiveError
from belief.grid import CandidateSet, candidates_from_config
from belief.journal import Journal, Record
from belief.least_squares import DEFAULT_STEP, StepConfig
from belief.posterior import PosteriorConfig, posterior_from_surrogate
from belief.proposers import BOProposer, Proposal, Proposer, RandomProposer, fit_surrogate
from belief.result import IdentificationResult, history_dataset
from belief.surrogate import SurrogateConfig
from belief.verdicts import VerdictConfig
from embeddings.base import Decoder
from embeddings.identity import Identity
from physics.objective import Objective, ObjectiveFunction, as_objective
from physics.parameters import ParameterSpace

__all__ = ["search", "problem_fingerprint", "default_n_init", "PROPOSERS", "posterior_config", "evaluations_record"]

#: the built-in proposers by name
PROPOSERS = ("bo", "random")


def _space_config(space: ParameterSpace) -> dict[str, Any]:
    return {"names": list(space.names), "units": list(space.units),
            "lower": [float(v) for v in space.lower], "upper": [float(v) for v in space.upper]}


def problem_fingerprint(objective: Objective, decoder: Decoder, grid: CandidateSet, proposer: Proposer, *,
                        seed: int, q: int, n_init: int, surrogate: SurrogateConfig) -> dict[str, Any]:
    """The JSON-able identity of an identification problem, stored in and checked against a journal."""
    return {
        "space": _space_config(objective.space), "decoder": decoder.config(), "grid": grid.config(),
        "seed": int(seed), "q": int(q), "n_init": int(n_init), "proposer": proposer.config(),
        "surrogate": {k: getattr(surrogate, k) for k in surrogate.__dataclass_fields__},
        "objective": objective.fingerprint(),
    }


def _validate_problem(objective: Objective | ObjectiveFunction, decoder: Decoder,
                      grid: CandidateSet) -> tuple[Objective, ParameterSpace]:
    """The objective (a plain function wrapped once, on the decoder's space) and its parameter space,
    after checking that objective, decoder and grid fit together."""
    if not isinstance(decoder, Decoder):
        raise BeliefError(f"decoder must be an embeddings.Decoder (.space, .dim, .bounds, .decode(z)), got "
                          f"{type(decoder).__name__}.")
    objective = as_objective(objective, None if isinstance(objective, Objective) else decoder.space)
    space = objective.space
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


def _validate_budget(grid: CandidateSet, decoder: Decoder, budget: Any, time_budget: Any, q: Any,
                     n_init: Any, seed: Any, reserved: int) -> tuple[int, int]:
    """(evaluations to reach, initial design size), after checking budgets and options; ``reserved``:
    the evaluations of ``budget`` kept for the finishing step."""
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool):
        raise BeliefError(f"seed must be an integer, got {seed!r}.")
    if budget is None and time_budget is None:
        raise BudgetError("give budget=N evaluations and/or time_budget=seconds; both are None.")
    if budget is not None:
        if not isinstance(budget, (int, np.integer)) or isinstance(budget, bool):
            raise BudgetError(f"budget must be an integer number of evaluations, got {budget!r}.")
        if budget < 1:
            raise BudgetError(f"budget must be >= 1 evaluation, got {budget!r}; a zero budget identifies nothing.")
        if budget <= reserved:
            raise BudgetError(f"budget={budget} leaves no evaluation of E for the search after the {reserved} of the "
                              f"Gauss-Newton step after it; give at least {reserved + 2}.")
        if budget - reserved > grid.size:
            kept = (f" leaves {budget - reserved} evaluations for the search after the {reserved} of the "
                    "Gauss-Newton step after it, which") if reserved else ""
            raise BudgetError(f"budget={budget}{kept} exceeds the {grid.size} grid cells (each cell is evaluated at "
                              "most once); use a finer grid or a smaller budget.")
    if time_budget is not None and not (isinstance(time_budget, (int, float)) and math.isfinite(time_budget)
                                        and time_budget > 0):
        raise BudgetError(f"time_budget must be a positive number of seconds, got {time_budget!r}.")
    if not isinstance(q, (int, np.integer)) or q < 1:
        raise BudgetError(f"q (cells per batch) must be an integer >= 1, got {q!r}.")
    n_target = int(budget) - reserved if budget is not None else int(grid.size)     # the search's evaluations
    if n_init is None:
        n_init = default_n_init(decoder.dim)
    if not isinstance(n_init, (int, np.integer)) or n_init < 1:
        raise BudgetError(f"n_init must be an integer >= 1, got {n_init!r}.")
    return n_target, int(n_init)


def _proposer(proposer: Proposer | str, seed: int, surrogate: SurrogateConfig, n_init: int) -> Proposer:
    """The proposer object: a built-in one by name (:data:`PROPOSERS`), or ``proposer`` itself."""
    if isinstance(proposer, str):
        if proposer not in PROPOSERS:
            raise BeliefError(f"proposer must be one of {PROPOSERS} or a belief.Proposer, got {proposer!r}.")
        if proposer == "random":
            return RandomProposer(seed)
        if n_init < 2:
            raise BudgetError(f"proposer='bo' needs n_init >= 2 initial evaluations to fit the GP, got {n_init}.")
        return BOProposer(seed, surrogate=surrogate)
    if not isinstance(proposer, Proposer):
        raise BeliefError(f"proposer must be one of {PROPOSERS} or a belief.Proposer (propose, config), got "
                          f"{type(proposer).__name__}.")
    return proposer


def default_n_init(dim: int) -> int:
    """The initial design's size in a ``dim``-dimensional search when n_init is not given: max(5, d + 1)."""
    return max(5, int(dim) + 1)


def _carried_init(carry: Sequence[Record], n_init: int | None) -> int | None:
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


def posterior_config(posterior: PosteriorConfig | str | None) -> PosteriorConfig | None:
    """``posterior`` as a PosteriorConfig: a mode name gives that mode's defaults; None stays None (no P)."""
    if posterior is None or isinstance(posterior, PosteriorConfig):
        return posterior
    if posterior == "likelihood":
        return PosteriorConfig(mode="likelihood")
    if posterior == "minimizer":
        return PosteriorConfig(mode="minimizer")
    raise BeliefError(f"posterior must be 'likelihood', 'minimizer', a belief.PosteriorConfig or None, got "
                      f"{posterior!r}.")


def _callback_hook(callback: Callable[[int, xr.DataArray], None] | None, objective: Objective, grid: CandidateSet,
                   pcfg: PosteriorConfig | None, seed: int) -> Callable[[int, Sequence[Record], Proposal], None] | None:
    """after_batch hook of the driver that reports P (σ² by the iid rule or the known noise) before each batch."""
    if callback is None or pcfg is None:
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
    proposer: Proposer | Literal["bo", "random"] = "bo",
    q: int = 1,
    n_init: int | None = None,
    posterior: PosteriorConfig | Literal["likelihood", "minimizer"] | None = "likelihood",
    surrogate: SurrogateConfig | None = None,
    verdict_config: VerdictConfig | None = None,
    progress: bool = True,
    callback: Callable[[int, xr.DataArray], None] | None = None,
    carry: Sequence[Record] = (),
    finish_step: StepConfig | None = None,
    on_assess: Callable[[], None] | None = None,
    budget_counts: Literal["search", "all"] = "search",
) -> IdentificationResult:
    """Search ``grid`` by Algorithm 1 (module docstring) and return the belief over it.

    ``objective``: a physics.objective.Objective, or a plain function θ (shape ``D``) -> E (float)
    on ``decoder.space``; ``decoder``: an ``embeddings.Decoder``; ``grid``: a
    belief.grid.CandidateSet (``belief.Grid`` or ``belief.SobolCandidates``) over ``decoder.bounds``.
    ``budget``: evaluations; ``time_budget``: seconds (either or both); ``seed``: all randomness;
    ``journal``: SQLite path, resumed if it exists; ``proposer``: "bo", "random" or any
    belief.proposers.Proposer; ``q``: cells per batch; ``n_init``: initial design size (default
    max(5, d + 1)); ``posterior``: "likelihood", "minimizer" or a PosteriorConfig (σ², noise rule,
    level, ...; default σ²: the objective's, else the noise rule), None to skip P;
    ``surrogate``: the GP's options; ``verdict_config``: thresholds of the verdicts
    (belief.verdicts; ``refit=False`` skips the local Gauss-Newton check);
    ``callback(n_evaluations, P)``: called
    before every batch with a fitted surrogate (one extra pass over the grid per batch); ``carry``:
    evaluations made before this run, as batch 0 (belief.handoff builds them; ``n_init`` is their number);
    ``finish_step``: a Gauss-Newton step from the best evaluation that ends the run, counted in
    ``budget`` (module docstring) and recorded in ``config["finishing_step"]``; it moves nothing
    (belief.presets makes its point the best θ); ``on_assess()``: called once the search's evaluations
    are done, as those after it (assessment, finishing step) start; ``budget_counts``: "all" keeps
    the assessment's evaluations inside ``budget`` (module docstring), "search" counts the search's.
    """
    objective, space = _validate_problem(objective, decoder, grid)
    n_init = _carried_init(carry, n_init)
    pcfg = posterior_config(posterior)
    reserved = _reserved(objective, pcfg, budget=budget, finish_step=finish_step, budget_counts=budget_counts)
    n_target, n_init = _validate_budget(grid, decoder, budget, time_budget, q, n_init, seed, reserved)
    seed, scfg = int(seed), surrogate or SurrogateConfig()
    chooser = _proposer(proposer, seed, scfg, n_init)
    if isinstance(chooser, BOProposer) and n_target <= n_init:
        kept = f" leaves {n_target} evaluations for the search after the {reserved} of the Gauss-Newton " \
               "step after it:" if reserved else " is"
        warnings.warn(f"budget={budget if reserved else n_target}{kept} no more than the initial design of {n_init} "
                      f"cells: BO never runs and the result is the initial design's; give budget >= "
                      f"{n_init + 1 + reserved} (or a smaller n_init).", BudgetWarning, stacklevel=2)
    fp = problem_fingerprint(objective, decoder, grid, chooser, seed=seed, q=int(q), n_init=n_init, surrogate=scfg)
    if carry:
        fp["carried"] = _carried_fingerprint(carry)
    jr = Journal(journal, fp) if journal is not None else None
    try:
        out = run(objective, decoder, grid, chooser, Budget(n_target, time_budget, n_init, int(q)), journal=jr,
                  progress=progress, label=_label(chooser, decoder),
                  after_batch=_callback_hook(callback, objective, grid, pcfg, seed), carried=tuple(carry))
    finally:
        if jr is not None:
            jr.close()
    if on_assess is not None:
        on_assess()
    return _result(objective, decoder, grid, out, space=space, config=fp, pcfg=pcfg, scfg=scfg, seed=seed,
                   vcfg=verdict_config, extra={"budget": budget, "time_budget": time_budget}, finish_step=finish_step,
                   reserved=reserved)


def _reserved(objective: Objective, pcfg: PosteriorConfig | None, *, budget: int | None,
              finish_step: StepConfig | None, budget_counts: Literal["search", "all"]) -> int:
    """The evaluations of ``budget`` kept for after the search (module docstring): the finishing
    step's or, with ``budget_counts="all"``, the assessment's (its local refit is a default step)."""
    if budget_counts not in ("search", "all"):
        raise BeliefError(f"budget_counts must be 'search' or 'all', got {budget_counts!r}.")
    if budget is None or (finish_step is None and (budget_counts == "search" or pcfg is None)):
        return 0
    return finishing_cost(objective.space.dim, finish_step or DEFAULT_STEP,
                          converges=fits_to_convergence(objective, pcfg))


def with_belief(objective: Objective, result: IdentificationResult, *,
                posterior: PosteriorConfig | Literal["likelihood", "minimizer"] = "likelihood",
                surrogate: SurrogateConfig | None = None, verdict_config: VerdictConfig | None = None,
                seed: int) -> IdentificationResult:
    """``result`` of a search run with ``posterior=None``, assessed into its belief afterwards (the
    same as having searched with ``posterior``): the decoder and grid are rebuilt from its config."""
    from embeddings import decoder_from_config

    pcfg, scfg = posterior_config(posterior), surrogate or SurrogateConfig()
    assert pcfg is not None
    decoder = decoder_from_config(result.config["decoder"], objective.space)
    grid = candidates_from_config(result.config["grid"])
    records = result.records()
    model = fit_surrogate(records, grid, scfg)
    if model is None:
        raise ObjectiveError("fewer than 2 successful evaluations; the posterior needs at least 2.")
    belief = assess(objective, decoder, grid, records, model, config=pcfg, surrogate=scfg, seed=int(seed),
                    verdict_config=verdict_config)
    before = int((result.config.get("evaluations") or {}).get("after_search", 0))
    config = {**result.config, "posterior": pcfg.mode, "noise_var": belief.attrs.get("noise_var"),
              "noise_rule": belief.attrs.get("noise_rule"),
              "evaluations": evaluations_record(len(records), before + int(belief.attrs["assessment_evaluations"]))}
    return IdentificationResult(belief=belief, history=result.history, best_theta=result.best_theta,
                                best_error=result.best_error, config=config)


def _label(proposer: Proposer, decoder: Decoder) -> str:
    """The progress bar's name of a search: what it searches and how, e.g. ``identify[bo, full space]``
    or ``identify[random, 5-D DynamicsAutoencoder]`` (the proposer config's ``kind``, else its class)."""
    kind = proposer.config().get("kind") or type(proposer).__name__
    where = "full space" if isinstance(decoder, Identity) else f"{decoder.dim}-D {type(decoder).__name__}"
    return f"identify[{kind}, {where}]"


def evaluations_record(search: int, after: int) -> dict[str, int]:
    """``config["evaluations"]``: the search's evaluations of E, those after it (assessment, finishing
    step) and their total."""
    return {"search": int(search), "after_search": int(after), "total": int(search) + int(after)}


def _result(objective: Objective, decoder: Decoder, grid: CandidateSet, out: DriverResult, *, space: ParameterSpace,
            config: dict[str, Any], pcfg: PosteriorConfig | None, scfg: SurrogateConfig,
            seed: int, extra: dict[str, Any], vcfg: VerdictConfig | None = None,
            finish_step: StepConfig | None = None, reserved: int = 0) -> IdentificationResult:
    """The IdentificationResult of the driver's records: best θ, history, (with ``pcfg``) the Belief,
    (with ``finish_step``) the finishing step's record, and the evaluations of E made."""
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
    belief, after, finishing = None, 0, None
    if pcfg is not None:
        model = fit_surrogate(records, grid, scfg)
        if model is None:
            raise ObjectiveError(f"only {len(ok)} successful evaluation(s); the posterior needs at least 2.")
        belief = assess(objective, decoder, grid, records, model, config=pcfg, surrogate=scfg, seed=seed,
                        verdict_config=vcfg, finish_step=finish_step, reserved=reserved)
        after, finishing = int(belief.attrs["assessment_evaluations"]), belief.attrs.get("finishing_step")
        fit = belief.attrs.get("local_fit") or {}
        if fit.get("converged_fit") and float(fit["error"]) < float(best.error):     # the local fit's end point
            best_theta = best_theta.copy(data=np.asarray(fit["theta"], dtype=float))
            best = replace(best, error=float(fit["error"]))
    elif finish_step is not None:                   # no assessment to take it in
        counted = CountingObjective(objective)
        finishing = step_record(counted, best.theta, finish_step)[1]
        after = counted.evaluations
    segments = tuple(objective.segments)
    hist = history_dataset(records, latent_names=tuple(f"z{i}" for i in range(grid.dim)), space=space,
                           segments=segments)
    cfg = dict(config)
    cfg.update(extra)
    cfg.update({"posterior": pcfg.mode if pcfg else None, "stopped": out.stopped, "n_evaluations": len(records),
                "noise_var": None if belief is None else belief.attrs.get("noise_var"),
                "noise_rule": None if belief is None else belief.attrs.get("noise_rule"),
                "evaluations": evaluations_record(len(records), after)})
    if finish_step is not None:
        cfg["finishing_step"] = finishing
    return IdentificationResult(belief=belief, history=hist, best_theta=best_theta, best_error=float(best.error),
                                config=cfg)
