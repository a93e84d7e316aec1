"""Close the loop: identify, criticize the residual, add the effect it points to, re-identify, repeat.

One pass on trajectories split into *fit* and *held-out* ones:

1. identify θ̂ of the current model (T6 + effects added so far) on the fit trajectories
   (belief.identify, full-space BO with the honest posterior);
2. criticize: rank the catalog effects by what they explain of the held-out residual beyond the
   floor (criticism.search);
3. if an effect is found: add it, identify again in the extended space (warm-started at
   criticism's joint fit of (θ, η)), and measure the held-out error before (at θ̃, the model re-tuned by
   criticism, so the extra search of the second identification is not credited to the effect)
   and after, per trajectory.

Each pass also lists the parameters the re-tuning left at a bound of the box (belief.bounds):
those it moved there from θ̂, and those the identification already found pinned there (the
"at bound" verdict rule). A fit that ends on the box's edge would leave it if it could: model
inadequacy, not estimates (criticism.wider_box.retuned_at_bounds). Each is tested by one re-fit in a
box widened on its pinned side (criticism.wider_box): "box too narrow" when it moved past the old
bound and the fit error dropped significantly, else "compensation" for a missing effect or an
engine mismatch.

Before the first identification, effects the data show directly are added without a search
(:func:`shown_at_rest`: each catalog effect bound to the data, Effect.bind, that is then
Effect.evident, such as a floor tilted by degrees under the resting robot): a search would only
weigh their dynamics, while the resting pose already settles them. With ``read_contact`` the
flops' contact law goes first (criticism.contact): flat end caps join the model before the
mismatch stage, and the observations' offset that law reads joins it when evident.

Passes repeat (``passes``) until criticism finds nothing. Held-out trajectories never enter an
identification; the effect fit of criticism uses only the fit trajectories. With one trajectory
there is nothing to hold out: criticism alternates its time windows between fit and held-out,
and the before/after error is in-sample (the report says so).

The error is E = Σ ||x_i - x̂_i||² over ``horizon``-sample open-loop windows (physics.TrajectoryObjective,
``loss="squared"``; default 25 samples, 0.25 s at 100 Hz): over a window an effect's deviation
builds up, while over one sample sensor noise dominates.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from belief.bounds import AT_BOUND_TOLERANCE
from belief.grid import SobolCandidates
from belief.identify import identify
from belief.posterior import PosteriorConfig
from belief.proposers import BOProposer, SobolDesign, WarmStart
from belief.result import IdentificationResult
from criticism.contact import ContactReading, read_contact
from criticism.diagnosis import Diagnosis, Pass, read_components
from criticism.errors import CriticismError
from criticism.mismatch import MismatchConfig, MismatchReport, superseded
from criticism.residuals import residual_dataset, residual_summary
from criticism.revisit import revisit_stage
from criticism.run_estimate import Announcer, run_estimate
from criticism.search import CriticismConfig, criticize
from criticism.stage_journal import journalled_stage
from criticism.wider_box import WiderBoxConfig, check_wider_box, retuned_at_bounds, run_noise_var
from embeddings import Identity
from physics.actuator_choice import ActuatorMode, choose_actuator, has_readings
from physics.effects import Effect, catalog
from physics.objective import Objective
from physics.parameters import ParameterSpace
from physics.tensegrity import ModelOptions
from physics.trajectory_objective import TrajectoryObjective

__all__ = ["DiagnoseConfig", "Pass", "Diagnosis", "diagnose", "identify_from", "split_masks", "retuned_at_bounds",
           "shown_at_rest"]


@dataclass(frozen=True)
class DiagnoseConfig:
    """passes: most effects added; budget: evaluations per identification; candidates: Sobol cells
    of each identification; horizon, windows: of the error (module docstring); seed: all randomness;
    bound_tolerance: a re-tuned value within this fraction of the box width of a bound is at it
    (belief.bounds); mismatch: the mismatch stage (criticism.mismatch) run before the first
    identification, whose components the identification and the search then keep (None: off). It
    is on by default: measured data always carry engine mismatch, and on the engine's own data it
    keeps nothing (tests/criticism/test_mismatch.py), so the rest of the loop is as without it;
    measure_at_rest: add the effects the resting robot shows (:func:`shown_at_rest`) before identifying;
    read_contact: read the end caps' shape and the observations' offset from the flops first
    (criticism.contact; off by default: on the end caps it reads, the mismatch stage predicted
    held-out flops no better, docs/diagnose.md);
    revisit: when criticism ranks an effect first without finding it, try the components the stage
    rejected again with that effect in the model (criticism.revisit); suspects: how many of the
    ranking's best effects get such a look, so that one hidden below a smaller one still gets it
    (the pass takes the look that found its effect with the most evidence, revisit.chosen);
    wider_box: the test of the parameters the re-tuning left at a bound, a re-fit in a wider box
    (criticism.wider_box; None: untested); actuator: with encoder readings in the data, whether the
    actuator law read from them replaces the motor model before anything else runs
    (physics.actuator_choice: "auto" when it fits the readings better, "measured", "model")."""

    passes: int = 2
    budget: int = 40
    candidates: int = 2048
    horizon: int = 25
    windows: int = 3
    seed: int = 0
    criticism: CriticismConfig = field(default_factory=CriticismConfig)
    bound_tolerance: float = AT_BOUND_TOLERANCE
    mismatch: MismatchConfig | None = field(default_factory=MismatchConfig)
    measure_at_rest: bool = True
    read_contact: bool = False
    revisit: bool = True
    suspects: int = 3
    wider_box: WiderBoxConfig | None = field(default_factory=WiderBoxConfig)
    actuator: ActuatorMode = "auto"

    def __post_init__(self) -> None:
        if (self.passes < 1 or self.budget < 2 or self.candidates < self.budget or self.horizon < 1
                or self.suspects < 1):
            raise CriticismError("DiagnoseConfig needs passes >= 1, budget >= 2, candidates >= budget, "
                                 "horizon >= 1 and suspects >= 1.")
        if not (isinstance(self.bound_tolerance, (int, float)) and 0 <= self.bound_tolerance < 0.5):
            raise CriticismError(f"DiagnoseConfig.bound_tolerance must be a fraction of the box width in [0, 0.5), "
                                 f"got {self.bound_tolerance!r}.")
        if self.actuator not in ("auto", "measured", "model"):
            raise CriticismError(f"DiagnoseConfig.actuator must be 'auto', 'measured' or 'model', got "
                                 f"{self.actuator!r}.")
        if self.wider_box is not None and not isinstance(self.wider_box, WiderBoxConfig):
            raise CriticismError(f"DiagnoseConfig.wider_box must be a WiderBoxConfig or None (untested), got "
                                 f"{type(self.wider_box).__name__}.")


def split_masks(segments: Sequence[str], held_out: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """(fit, held) masks over segments "t{k}/w{j}": held = trajectories in ``held_out``; with none,
    odd windows are held out and even ones fit."""
    traj = np.array([int(s.split("/")[0][1:]) for s in segments])
    window = np.array([int(s.split("/")[1][1:]) for s in segments])
    held = np.isin(traj, list(held_out)) if len(held_out) else window % 2 == 1
    return ~held, held


def _held_errors(objective: Objective, theta: np.ndarray, held: np.ndarray) -> dict[str, float]:
    """Held-out E per trajectory (name "t{k}") at θ."""
    parts = np.asarray(objective.evaluate_parts(theta), float)
    out: dict[str, float] = {}
    for name, value, h in zip(objective.segments, parts, held, strict=True):
        if h:
            key = name.split("/")[0]
            out[key] = out.get(key, 0.0) + float(value)
    return out


def _record_after(step: Pass, added: str, extended: Objective, ident: IdentificationResult,
                  held: np.ndarray) -> None:
    """Fill ``step``'s "after" fields: the effect ``added``, the extended model's names, θ̂ of the
    re-identification ``ident``, its held-out errors and its Belief; an effect found on the second
    look has its sizes checked against those it had alone (Revisit.check_sizes)."""
    step.added, step.names_after = added, extended.space.names
    step.theta_after = np.asarray(ident.best_theta, float)
    step.held_after = _held_errors(extended, step.theta_after, held)
    look, belief = step.second_look, ident.belief
    step.belief_after = look.check_sizes(belief) if look is not None and belief is not None else belief


def identify_from(objective: Objective, warm: np.ndarray | None, *, budget: int, candidates: int, seed: int,
                  journal: Path | None = None, progress: bool = True,
                  posterior: PosteriorConfig | None = None) -> IdentificationResult:
    """Full-space BO on ``objective`` over ``candidates`` Sobol cells, ``budget`` evaluations;
    ``warm`` (D,), a fit the caller already has, becomes cell 0 and is evaluated first;
    ``posterior``: the belief's options (default: the likelihood posterior's)."""
    space = objective.space
    decoder = Identity(space)
    include = None if warm is None else decoder.encode(np.clip(warm, space.lower, space.upper))[None]
    grid = SobolCandidates(decoder.bounds, n=candidates, seed=seed, include=include)
    proposer = "bo" if warm is None else BOProposer(seed, initial=WarmStart([0], SobolDesign(seed)))
    return identify(objective, decoder, grid, budget=budget, seed=seed, proposer=proposer,
                    journal=journal, progress=progress, posterior=posterior or PosteriorConfig())


def _check_held_out(n: int, held_out: Sequence[int] | None) -> list[int]:
    if held_out is None:
        return list(range(n - max(1, n // 3), n)) if n >= 2 else []
    held = sorted({int(k) for k in held_out})
    if any(k not in range(n) for k in held) or (held and len(held) == n):
        raise CriticismError(f"held_out must name some (not all) of the {n} trajectories by index 0..{n - 1}, got "
                             f"{list(held_out)}.")
    return held


def shown_at_rest(trajectories: Sequence[xr.Dataset], effects: Sequence[Effect]) -> tuple[Effect, ...]:
    """The ``effects`` that, bound to ``trajectories`` (Effect.bind), are evident (Effect.evident):
    the data show them at rest beyond doubt, so they join the model without a search."""
    bound = [e.bind(trajectories) for e in effects]
    return tuple(b for b in bound if b.evident)


def _with_read_bias(tries: Sequence[Effect], contact: ContactReading | None) -> list[Effect]:
    """``tries`` with the catalog's sensor bias replaced by the one the flops' contact law reads."""
    if contact is None or contact.bias is None:
        return list(tries)
    return [contact.bias if e.name == contact.bias.name else e for e in tries]


def _warm(stage: MismatchReport | None, shown: Sequence[Effect]) -> np.ndarray | None:
    """The first identification's warm start: the stage's θ, extended by the measured values of the
    effects shown at rest (their parameters' nominal values); None without a stage that kept or
    measured anything."""
    if stage is None or not (stage.effects or shown):
        return None
    return np.r_[np.asarray(stage.theta, float), [p.nominal for e in shown for p in e.parameters()]]


def diagnose(trajectories: Sequence[xr.Dataset], *, held_out: Sequence[int] | None = None,
             effects: Sequence[Effect] | None = None, config: DiagnoseConfig = DiagnoseConfig(),
             journal_dir: str | os.PathLike[str] | None = None, options: ModelOptions | None = None,
             n_workers: int = 2, progress: bool = True, space: ParameterSpace | None = None,
             say: Callable[[str], None] | None = None) -> Diagnosis:
    """Run the loop of the module docstring on ``trajectories`` (xarray Datasets, docs/data-format.md).

    held_out: indices of the trajectories kept for scoring (default: the last third, at least one,
    when there are two or more); effects: the catalog to try (default physics.effects.catalog());
    journal_dir: the mismatch stage (criticism.stage_journal) and the identifications are journalled
    there and resume after an interruption; options: physics.ModelOptions of the model; space: the
    T6's prior box (default ParameterSpace.t6()), which every stage keeps as effects join the model
    (TrajectoryObjective.with_effects); say: given, a rough run-time estimate and one line per stage
    as it starts and ends go through it (criticism.run_estimate), whatever ``progress``."""
    data = list(trajectories)
    if not data:
        raise CriticismError("diagnose needs at least one trajectory.")
    held_idx = _check_held_out(len(data), held_out)
    fit_idx = [k for k in range(len(data)) if k not in held_idx]
    tries = list(effects) if effects is not None else list(catalog())
    journals = Path(journal_dir) if journal_dir is not None else None
    if journals is not None:
        journals.mkdir(parents=True, exist_ok=True)
    full = TrajectoryObjective(data, space=space, horizon=config.horizon, loss="squared", windows=config.windows,
                               options=options, n_workers=n_workers)
    announce = Announcer(say)
    try:
        fit, held = split_masks(full.segments, held_idx)
        fit_objective = full.select(fit_idx)
        if say is not None:
            announce.line(run_estimate(fit_objective, config, n_effects=len(tries)))
        first = [n for n, on in (("contact reading", config.read_contact), ("mismatch stage", config.mismatch))
                 if on] or ["first model"]
        actuator = None
        if config.actuator != "model" and has_readings(data):
            with announce.stage("actuator reading"):
                actuator = choose_actuator(data, space or ParameterSpace.t6(), mode=config.actuator, options=options)
        with announce.stage(" and ".join(first)):
            contact = read_contact(data) if config.read_contact else None
            read = read_components(actuator, contact)
            tries = _with_read_bias(tries, contact)
            stage = (journalled_stage(full.with_effects(read), fit, held_idx, config=config.mismatch,
                                      journal_dir=journals, progress=progress)
                     if config.mismatch is not None else None)
        shown = shown_at_rest(data, superseded(tries, stage.effects if stage else ())) if config.measure_at_rest else ()
        added: tuple[Effect, ...] = read + (stage.effects if stage is not None else ()) + shown
        tries = superseded(tries, added)
        with announce.stage("identification 0"):
            ident = identify_from(fit_objective.with_effects(added), _warm(stage, shown), budget=config.budget,
                                  candidates=config.candidates, seed=config.seed, journal=_journal(journals, 0),
                                  progress=progress)
        first_belief, passes = ident.belief, []
        for k in range(config.passes):
            model = full.with_effects(added)
            with announce.stage(f"pass {k + 1} criticism"):
                step = _criticize(model, ident, tries, (fit, held), config=config, progress=progress)
                passes.append(step)
                if stage is not None and config.mismatch is not None and config.revisit:
                    step.looks = revisit_stage(model, step.criticism, stage, fit, held, held_idx,
                                               config=config.mismatch, criticism=config.criticism,
                                               suspects=config.suspects, progress=progress,
                                               journal_dir=None if journals is None else journals / f"revisit{k}")
            row = step.found
            if row is None:
                break
            added = added + step.additions
            tries = superseded(tries, added)
            with announce.stage(f"identification {k + 1} (with {row.name})"):
                ident = identify_from(fit_objective.with_effects(added), np.asarray(row.theta, float),
                                      budget=config.budget, candidates=config.candidates, seed=config.seed + k + 1,
                                      journal=_journal(journals, k + 1), progress=progress)
            _record_after(step, row.name, full.with_effects(added), ident, held)
        settings = _settings(config, fit_idx, full.segments)
        return Diagnosis(passes, tuple(e.name for e in added), held_idx, first_belief, settings, stage, shown, contact,
                         actuator)
    finally:
        full.close()


def _criticize(model: TrajectoryObjective, ident: IdentificationResult, tries: Sequence[Effect],
               masks: tuple[np.ndarray, np.ndarray], *, config: DiagnoseConfig, progress: bool) -> Pass:
    """One pass before anything is added: criticism of ``model`` at the identification's θ̂ over
    the catalog ``tries``, with the residual's structure, the parameters the re-tuning pinned at a
    bound and their wider-box test, and the held-out error at the re-tuned θ̃; masks: (fit, held)
    over the segments."""
    fit, held = masks
    theta = np.asarray(ident.best_theta, float)
    structure = residual_summary(residual_dataset(model, theta))
    crit = criticize(model, theta, fit=fit, held=held, effects=tries, config=config.criticism,
                     structure=structure, progress=progress)
    pinned = retuned_at_bounds(model.space, theta, crit.theta, ident.belief, tolerance=config.bound_tolerance)
    tested = (None if config.wider_box is None else
              check_wider_box(model, crit.theta, pinned, fit, noise_var=run_noise_var(ident.belief, model),
                              config=config.wider_box))
    retuned = crit.theta          # re-tuned on the fit trajectories: the fair "before"
    return Pass(tuple(e.name for e in model.effects), model.space.names, retuned, crit,
                _held_errors(model, retuned, held), at_bounds=pinned, wider_box=tested)


def _settings(config: DiagnoseConfig, fit_idx: Sequence[int], segments: Sequence[str]) -> dict[str, Any]:
    """The settings a Diagnosis records: the error's, the identifications' and the loop's."""
    return {"horizon": config.horizon, "windows": config.windows, "budget": config.budget,
            "candidates": config.candidates, "seed": config.seed, "passes": config.passes,
            "bound_tolerance": config.bound_tolerance, "measure_at_rest": config.measure_at_rest,
            "read_contact": config.read_contact, "revisit": config.revisit, "actuator": config.actuator,
            **({"suspects": config.suspects} if config.suspects != 1 else {}),
            "fit_trajectories": list(fit_idx), "segments": list(segments)}


def _journal(directory: Path | None, k: int) -> Path | None:
    return None if directory is None else directory / f"identify_pass{k}.sqlite"
