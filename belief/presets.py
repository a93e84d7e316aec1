"""Named identification recipes: which searches run over the one driver, in what order, and what
finishes them. ``identify(objective, budget=..., seed=...)`` without a decoder and grid runs
:data:`DEFAULT_PRESET`, the best recipe measured (docs/benchmarks.md).

::

    preset        stage 1: latent grid          stage 2: full space (D-dim)            finish
    handoff-gn    BO, ``latent`` evaluations    BO over Sobol θ, stage 1 carried        one Gauss-Newton step
    handoff-local BO, ``latent`` evaluations    BO over Sobol θ, stage 1 carried        the local stage
    handoff       BO, ``latent`` evaluations    BO over Sobol θ, stage 1 carried        -
    bo-gn         -                             BO over Sobol θ                         one Gauss-Newton step
    bo-local      -                             BO over Sobol θ                         the local stage
    bo            -                             BO over Sobol θ                         -
    random        -                             random Sobol θ                          -
    latent        BO to the budget              -                                       -

Budget: ``budget`` counts every evaluation of E the search and its assessment make: stage 2 (the
latent grid for ``latent``) runs to ``budget`` less :func:`reserved_evaluations` (belief.assess.
finishing_cost: D + 1 + len(lengths), 19 for the T6's D = 15; the calibrated noise rule's fit to
convergence instead when it runs), the most the assessment spends after it (σ²'s residuals, the
verdicts' local refit, belief.verdicts). A ``-gn`` preset's finishing step is that refit's step,
taken whatever the verdicts, so such a run makes exactly ``budget`` evaluations; the others make
at most ``budget`` (the refit runs only when a parameter narrowed). ``config["evaluations"]``
records the search's, those after it and the total. The ``-local`` presets' local stage spends
its own evaluations (:class:`~belief.local_belief.LocalConfig`) after ``budget``; the summary
counts them apart. The latent
stage needs a decoder over the objective's space: ``decoder=`` (a trained one,
``tensegrid train-embedding``), else the pretrained one shipped for the T6's default box
(embeddings.pretrained); with neither, ``handoff`` presets run without their latent stage and
say so (:class:`PresetWarning`, ``result.config["stages"]``). The full space is searched over
``candidates`` Sobol points when D > 4, else a regular grid of ``points_per_dim`` per axis.

The finishing step moves θ off the candidates: when it lowers E, ``best_theta`` and
``best_error`` are its point, and ``config["local_step"]`` records both errors and its
evaluations. P stays the posterior over stage 2's cells (the step is not journalled; a resumed run
repeats it).

The local stage (belief.local_belief) replaces P by a belief at the data's resolution: local fits,
σ² measured from the data, Algorithm 1 on a grid of the directions the data pin. It is not counted
in ``budget`` (``config["local_stage"]`` records its evaluations); where it cannot run (no
residuals, nothing pinned) the search's own belief stands, with a :class:`PresetWarning`.
"""
from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from belief.assess import finishing_cost, fits_to_convergence
from belief.errors import BeliefError, BudgetError
from belief.grid import Grid, SobolCandidates
from belief.handoff import continue_in
from belief.least_squares import DEFAULT_STEP, StepConfig
from belief.local_belief import DEFAULT_LOCAL, LocalConfig, NoLocalStage, local_stage
from belief.posterior import PosteriorConfig
from belief.result import IdentificationResult
from belief.search import posterior_config, search, with_belief
from embeddings import Decoder, Identity
from embeddings.pretrained import pretrained_decoder
from physics.measurements import MeasurementPrior
from physics.objective import Objective, ObjectiveFunction, as_objective
from physics.parameters import ParameterSpace

__all__ = ["Preset", "PRESETS", "DEFAULT_PRESET", "PresetWarning", "minimum_budget", "reserved_evaluations",
           "run_preset"]


class PresetWarning(UserWarning):
    """A preset ran without one of its stages (no latent decoder for this space, no residuals)."""


@dataclass(frozen=True)
class Preset:
    """A recipe: ``latent`` evaluations of BO in a decoder's grid (0: none), then ``search`` in the full
    space ("bo", "random", or None to stay in the latent grid), then optionally ``local_step`` (one
    Gauss-Newton step) or ``local_stage`` (belief.local_belief)."""

    name: str
    latent: int = 0
    search: Literal["bo", "random"] | None = "bo"
    local_step: bool = False
    candidates: int = 4096
    points_per_dim: int = 11
    local_stage: bool = False

    def __post_init__(self) -> None:
        if self.latent < 0 or (self.search is None and self.latent != 0) or self.candidates < 1:
            raise BeliefError(f"Preset {self.name!r}: latent must be >= 0 (0 when search is None: the latent stage "
                              f"then runs to the budget) and candidates >= 1, got {self.latent}, {self.candidates}.")
        if self.local_stage and (self.local_step or self.search is None):
            raise BeliefError(f"Preset {self.name!r}: the local stage finishes a full-space search, instead of the "
                              "Gauss-Newton step; give one of local_step and local_stage.")

    @property
    def uses_latent(self) -> bool:
        return self.latent > 0 or self.search is None


PRESETS: dict[str, Preset] = {p.name: p for p in (
    Preset("handoff-gn", latent=15, local_step=True),
    Preset("handoff-local", latent=15, local_stage=True),
    Preset("handoff", latent=15),
    Preset("bo-gn", local_step=True),
    Preset("bo-local", local_stage=True),
    Preset("bo"),
    Preset("random", search="random"),
    Preset("latent", search=None),
)}

#: the recipe ``identify`` runs when given no decoder and grid
DEFAULT_PRESET = "handoff-gn"

#: on_stage(name) is called as each stage starts: "latent", "search", "local_step" (as stage 2's
#: assessment starts, which takes the step: every evaluation from there on is the step's) or "local"
OnStage = Callable[[str], None]


def resolve(preset: str | Preset) -> Preset:
    """The :class:`Preset` named ``preset`` (or ``preset`` itself)."""
    if isinstance(preset, Preset):
        return preset
    if preset not in PRESETS:
        raise BeliefError(f"unknown preset {preset!r}; choose one of {sorted(PRESETS)} (belief.presets).")
    return PRESETS[preset]


def _latent_decoder(preset: Preset, objective: Objective, decoder: Decoder | None) -> tuple[Preset, Decoder | None]:
    """The latent stage's decoder, or the preset without that stage (warned) when there is none."""
    if not preset.uses_latent:
        if decoder is not None:
            raise BeliefError(f"preset {preset.name!r} searches the full space only; decoder= is for the presets "
                              f"with a latent stage ({sorted(n for n, p in PRESETS.items() if p.uses_latent)}).")
        return preset, None
    found = decoder if decoder is not None else pretrained_decoder(objective.space)
    if found is not None:
        return preset, found
    if preset.search is None:
        raise BeliefError(f"preset {preset.name!r} searches a latent grid and needs decoder= (a trained decoder over "
                          "the objective's space, `tensegrid train-embedding`); none is shipped for this space.")
    warnings.warn(f"preset {preset.name!r}: no latent decoder for this parameter space (pass decoder=, written by "
                  "`tensegrid train-embedding`); running it without the latent stage.", PresetWarning, stacklevel=3)
    return replace(preset, latent=0), None


def reserved_evaluations(preset: str | Preset, space_dim: int, step: StepConfig = DEFAULT_STEP, *,
                         converges: bool = False) -> int:
    """The evaluations of the budget kept for after the search (module docstring): the most stage 2's
    assessment spends (``step``: the finishing step of a ``-gn`` preset; ``converges``: the calibrated
    noise rule's fit, belief.assess.fits_to_convergence); 0 for a ``-local`` preset, whose search
    has no assessment."""
    recipe = resolve(preset)
    if recipe.local_stage:
        return 0
    return finishing_cost(space_dim, step if recipe.local_step else DEFAULT_STEP, converges=converges)


def minimum_budget(preset: str | Preset, space_dim: int, step: StepConfig = DEFAULT_STEP, *,
                   converges: bool = False) -> int:
    """The smallest budget ``preset`` runs with in a D = ``space_dim`` space: its latent evaluations, one
    more (at least two: the posterior fits a GP) and :func:`reserved_evaluations`."""
    recipe = resolve(preset)
    return reserved_evaluations(recipe, space_dim, step, converges=converges) + max(recipe.latent + 1, 2)


def _full_space(space_dim: int, decoder: Identity, preset: Preset, seed: int) -> Grid | SobolCandidates:
    if space_dim > 4:
        return SobolCandidates.for_decoder(decoder, n=preset.candidates, seed=seed)
    return Grid.for_decoder(decoder, points_per_dim=preset.points_per_dim)


def _latent_journal(journal: str | os.PathLike[str] | None) -> str | None:
    return None if journal is None else os.path.splitext(os.fspath(journal))[0] + "-latent.sqlite"


def _search(objective: Objective, preset: Preset, decoder: Decoder | None, *, budget: int, seed: int,
            journal: str | os.PathLike[str] | None, on_stage: OnStage, finish_step: StepConfig | None,
            options: dict[str, Any]) -> IdentificationResult:
    """Stages 1 and 2 of the module docstring, ``budget`` evaluations in all, ``finish_step`` taken
    in stage 2's assessment (belief.search), which ``budget`` counts."""
    space = objective.space
    options = {**options, "budget_counts": "all"}
    stepping = None if finish_step is None else (lambda: on_stage("local_step"))
    if preset.search is None:
        assert decoder is not None
        on_stage("latent")
        return search(objective, decoder, Grid.for_decoder(decoder, points_per_dim=preset.points_per_dim),
                      budget=budget, seed=seed, journal=journal, finish_step=finish_step, on_assess=stepping,
                      **options)
    full = Identity(space)
    if preset.latent == 0:
        on_stage("search")
        return search(objective, full, _full_space(space.dim, full, preset, seed), budget=budget, seed=seed,
                      journal=journal, proposer=preset.search, finish_step=finish_step, on_assess=stepping, **options)
    assert decoder is not None
    on_stage("latent")
    quiet = {k: v for k, v in options.items() if k not in ("posterior", "verdict_config", "budget_counts")}
    first = search(objective, decoder, Grid.for_decoder(decoder, points_per_dim=preset.points_per_dim),
                   budget=preset.latent, seed=seed, journal=_latent_journal(journal), posterior=None, **quiet)
    on_stage("search")
    return continue_in(first, objective, full, budget=budget, seed=seed, n=preset.candidates, journal=journal,
                       proposer=preset.search, finish_step=finish_step, on_assess=stepping, **options)


def _finish(result: IdentificationResult) -> IdentificationResult:
    """The finishing step stage 2 took (``config["finishing_step"]``, belief.search): its point becomes
    the best when it lowers E. Where it could not be taken (a plain function has no residual
    vectors) the search's best stays, with a warning."""
    record = result.config.pop("finishing_step", None) or {"skipped": "no step was taken"}
    if "skipped" in record:
        warnings.warn(f"preset {result.config['preset']!r}: the finishing Gauss-Newton step needs residual vectors "
                      f"and a simulation that runs at the best θ ({record['skipped']}); the search's best θ is kept.",
                      PresetWarning, stacklevel=3)
        result.config["stages"] = result.config["stages"][:-1]
        return result
    error, start_error = float(record["error"]), float(record["start_error"])
    result.config["local_step"] = {"start_error": start_error, "error": error,
                                   "evaluations": int(record["evaluations"]), "improved": bool(error < start_error)}
    if error < result.best_error:
        result.best_theta = result.best_theta.copy(data=np.asarray(record["theta"], dtype=float))
        result.best_error = error
    return result


def _local_posterior(options: dict[str, Any]) -> PosteriorConfig:
    """The posterior options of a preset that finishes with the local stage (its level and, where it
    cannot run, the search's own belief); the local stage needs the likelihood mode."""
    posterior = options.get("posterior", "likelihood")
    pcfg = PosteriorConfig() if posterior == "likelihood" else posterior
    if not isinstance(pcfg, PosteriorConfig) or pcfg.mode != "likelihood":
        raise BeliefError("the local stage (presets '*-local') builds a likelihood posterior; leave posterior= "
                          "at 'likelihood' or pass a PosteriorConfig in that mode.")
    return pcfg


def _finish_locally(objective: Objective, result: IdentificationResult, pcfg: PosteriorConfig, *, name: str, seed: int,
                    local: LocalConfig, prior: MeasurementPrior | None, journal: str | os.PathLike[str] | None,
                    options: dict[str, Any]) -> IdentificationResult:
    """The local stage after the global search; the global belief when it cannot run (nothing pinned,
    no residuals: a :class:`PresetWarning` says why)."""
    try:
        return local_stage(objective, result, seed=seed, config=local, level=pcfg.level, prior=prior,
                           verdict_config=options.get("verdict_config"), journal=journal,
                           progress=bool(options.get("progress", True)))
    except NoLocalStage as exc:
        warnings.warn(f"preset {name!r}: the local stage needs residual vectors and a "
                      f"direction the data pin ({exc}); the global search's belief is kept.", PresetWarning,
                      stacklevel=4)
    out = with_belief(objective, result, posterior=pcfg, surrogate=options.get("surrogate"),
                      verdict_config=options.get("verdict_config"), seed=seed)
    out.config["local_stage"] = None
    return out


def run_preset(objective: Objective | ObjectiveFunction, preset: str | Preset = DEFAULT_PRESET, *, budget: int,
               seed: int, decoder: Decoder | None = None, journal: str | os.PathLike[str] | None = None,
               space: ParameterSpace | None = None, workers: int = 1, step: StepConfig = DEFAULT_STEP,
               local: LocalConfig = DEFAULT_LOCAL, measurements: MeasurementPrior | None = None,
               on_stage: OnStage | None = None, **options: Any) -> IdentificationResult:
    """Identify θ by the recipe ``preset`` (module docstring) in ``budget`` evaluations.

    ``budget`` counts every evaluation of E, the finishing step's included (module docstring);
    ``decoder``: the latent stage's decoder (default: the pretrained one for this space, if any);
    ``journal``: SQLite path of the full-space stage (the latent stage journals beside it, suffix
    ``-latent``); ``space``, ``workers``: for a plain function θ -> E only, wrapped once
    (physics.objective.as_objective); ``on_stage(name)``: called as "latent", "search",
    "local_step" (stage 2's assessment, which takes the step), "local" start; ``options`` go to each
    stage (posterior, surrogate, verdict_config, q, n_init, time_budget, progress, ...;
    belief.search.search), the proposer being the preset's.
    """
    if isinstance(budget, bool) or not isinstance(budget, (int, np.integer)) or budget < 1:
        raise BudgetError(f"budget must be >= 1 evaluation, got {budget!r}; a zero budget identifies nothing.")
    if {"proposer", "finish_step", "on_assess", "budget_counts"} & set(options):
        raise BeliefError("a preset chooses its own proposers and finishing step (step=, on_stage=) and counts every "
                          "evaluation in budget=; pass a grid and decoder for a search with proposer=, finish_step=, "
                          "on_assess= or budget_counts=.")
    if isinstance(objective, Objective) and (space is not None or workers != 1):
        raise BeliefError("space= and workers= wrap a plain function θ -> E; this objective has its own space "
                          f"({list(objective.space.names)}): leave them out.")
    objective = as_objective(objective, space, workers=workers)
    recipe, latent = _latent_decoder(resolve(preset), objective, decoder)
    on_stage = on_stage or (lambda name: None)
    pcfg = _local_posterior(options) if recipe.local_stage else None
    converges = fits_to_convergence(objective, posterior_config(options.get("posterior", "likelihood")))
    assessed = recipe.local_step or posterior_config(options.get("posterior", "likelihood")) is not None
    cost = reserved_evaluations(recipe, objective.space.dim, step, converges=converges) if assessed else 0
    least, search_budget = cost + max(recipe.latent + 1, 2), budget - cost
    if budget < least:
        raise BudgetError(f"budget={budget} is too small for preset {recipe.name!r}: {recipe.latent} latent "
                          f"evaluations and the {cost} of the Gauss-Newton step after the search leave too few for it "
                          f"(the posterior needs 2 evaluations); give at least {least}.")
    result = _search(objective, recipe, latent, budget=budget, seed=seed, journal=journal, on_stage=on_stage,
                     finish_step=step if recipe.local_step else None,
                     options=options if pcfg is None else {**options, "posterior": None})
    if pcfg is not None:
        on_stage("local")
        result = _finish_locally(objective, result, pcfg, name=recipe.name, seed=seed, local=local, prior=measurements,
                                 journal=journal, options=options)
    result.config["preset"] = recipe.name
    result.config["stages"] = ([f"latent ({type(latent).__name__}, {recipe.latent or search_budget} evaluations)"]
                               if latent is not None else []) + \
        ([f"{recipe.search} over the full space"] if recipe.search else []) + \
        ([f"Gauss-Newton step ({cost} evaluations)"] if recipe.local_step else []) + \
        (["local stage (belief.local_belief)"] if pcfg is not None and result.config.get("local_stage") else [])
    if recipe.local_step:
        result = _finish(result)
    return result
