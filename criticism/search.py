"""Catalog search: which physical effect the identified model lacks, judged on held-out data against a floor.

Given an objective with segments and effects (:class:`physics.effect_objective.EffectObjective`,
e.g. physics.TrajectoryObjective with ``loss="squared"``), the identified θ̂, and a split of its
segments into *fit* segments F and *held-out* segments H:

1. the base errors E_F(θ̃), E_H(θ̃) of the current model at the re-tuned θ̃ (below);
2. for each catalog effect e not yet in the model (bound to the data first, Effect.bind: a floor
   tilt the resting robot shows is measured, and its fit keeps near that measurement): its
   parameters η_e are fitted on F with θ̂ held (a grid of ``grid`` values over each parameter's
   box, then ``refine`` values around the best, one parameter at a time), and scored on H:

       explained_e = 1 - E_H(θ̃, η̂_e) / E_H(θ̃)                          (held-out fraction)
       evidence_e  = K_F ln(E_F(θ̃) / E_F(θ̃, η̂_e)) + K_H ln(E_H(θ̃) / E_H(θ̃, η̂_e)) - k_e ln(K_F + K_H)

   the second a BIC difference over all the data (in-sample on F, out-of-sample on H), with
   K_F, K_H the effective residual counts of F and H of the model with the effect
   (belief.noise.effective_size of its residuals: time correlation and cross-coordinate
   redundancy make the raw count overstate the evidence; a model that explains the structure
   leaves whiter residuals and so earns a larger K) and k_e the effect's parameter count.
   ``K ln(E_0/E_1)`` is twice the log-likelihood ratio of two Gaussian models with the residual
   variance profiled out. An effect whose place the data must choose (Effect.placements: a point
   mass on one of 6 rods, toward either end) is screened at each of its m placements; the best is
   kept and charged a further 2 ln m (a uniform prior over the placements);
   Before step 2 the model's own parameters are *re-tuned* (:func:`polish`: a bounded
   least-squares refinement of all of them on F, belief.least_squares): an imperfect θ̂ leaves
   residual that any extra freedom absorbs, so effects are fitted and scored against the
   re-tuned θ̃ — the floor — not against θ̂. The table's floor row says how much of the held-out
   residual re-tuning alone removed.
   The ``joint`` best screened effects are then refined together with the model's parameters
   (least squares over (θ, η) from (θ̃, η̂): an effect the model's parameters partly mimic, such
   as a stiffening cable law against the stiffness, is only seen when both move at once), and
   the base gets a second refinement of its own, so both had the same search; those effects
   are scored against the base after it;
3. verdict: the effect with the largest evidence is **found** if evidence_e >= ``min_evidence``
   and explained_e >= ``min_fraction``. When the data carry two effects, each alone leaves the
   other's structured residual and so earns little evidence; then, if the best has positive
   evidence, the two best are refined together, and each one's *conditional* evidence is scored: the
   pair against the model with the other one only (same formula). If both reach
   ``min_evidence`` and the pair explains ``min_fraction`` of the held-out error, the first of
   the two is found (the next pass looks for the second). Either way the effect must also
   *replicate* (criticism.replication): fitted without each fit trajectory, it must not make that
   trajectory worse (``min_replication``), which a freedom that absorbs each trajectory's own
   model error does. When the top effect passes both bars but fails that check with θ̃ held, it
   gets the *refit* check (``refit_replication``): the model alone and the model with the effect,
   each re-tuned without the trajectory left out, and the effect must not make it worse.
   Otherwise **unexplained**, with where the residual concentrates (criticism.residuals).
   When several effects would each be found (a sensor bias and a larger end-cap radius both
   lift the resting robot), they are *contenders* (:func:`_contest`): all are scored with the
   same effective counts K̄_F, K̄_H (their mean), so that a difference of evidence between two
   contenders is a log-likelihood ratio on the same data, not a difference of their K. The
   contender with the largest evidence is ranked first; the others within ``tie`` of it are not
   told apart by the data and are reported as ``alternatives`` to the found one.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from belief import least_squares
from belief.least_squares import LeastSquaresConfig, LocalFit
from criticism.candidate import Candidate, effective_counts, place_text, rescore, scored, values_text
from criticism.errors import CriticismError
from criticism.replication import refit_replication_gains, replication_gains
from criticism.screening import effect_start, fit_effect
from physics.effect_objective import EffectObjective
from physics.effects import Effect, effect_from_config
from physics.objective import Objective

__all__ = ["CriticismConfig", "Candidate", "Criticism", "VERDICTS", "criticize", "polish"]

VERDICTS = ("found", "unexplained")


@dataclass(frozen=True)
class CriticismConfig:
    """grid, refine: values per parameter in the first and second pass of an effect's screening
    fit; min_evidence (ΔBIC, natural-log units ×2) and min_fraction (held-out explained fraction)
    an effect must reach to be found; joint: how many of the best screened effects are refined
    jointly with the model's parameters (0: none); tie: an evidence difference below which two
    effects are indistinguishable by evidence (6: "strong" on Kass and Raftery's scale); local:
    the least-squares refinement of the re-tuning and of the joint fits (up to four runs, each from
    the last's best point: one run stops short on the ridges where an effect's size trades off the
    model's parameters, e.g. a drag against the cables' damping); min_replication: the
    gain on each fit trajectory the effect must reach when fitted on the others
    (criticism.replication; None: no check); refit_replication: whether an effect that passes
    both bars but does not replicate with θ̃ held is checked again with the model's parameters
    re-tuned as well (criticism.replication, the refit check)."""

    grid: int = 7
    refine: int = 5
    min_evidence: float = 10.0
    min_fraction: float = 0.3
    joint: int = 3
    tie: float = 6.0
    local: LeastSquaresConfig = field(default_factory=lambda: LeastSquaresConfig(rounds=4))
    min_replication: float | None = 0.0
    refit_replication: bool = True

    def __post_init__(self) -> None:
        if self.grid < 3 or self.refine < 3:
            raise CriticismError(f"CriticismConfig needs grid >= 3 and refine >= 3 values, got {self.grid}, "
                                 f"{self.refine}.")
        if not (self.min_evidence >= 0 and 0 <= self.min_fraction < 1 and self.tie >= 0):
            raise CriticismError("CriticismConfig needs min_evidence >= 0, min_fraction in [0, 1) and tie >= 0.")
        if self.min_replication is not None and not self.min_replication < 1:
            raise CriticismError(f"CriticismConfig.min_replication is a held-out gain below 1 (or None: no check), "
                                 f"got {self.min_replication}.")


@dataclass
class Criticism:
    """The outcome of :func:`criticize` (module docstring): θ̃ the re-tuned parameters (the floor),
    ranking (effects, best evidence first), floor (what re-tuning removed of the held-out error of
    θ̂), verdict, found (the winning Candidate or None), base errors at θ̃ and effective sizes, and
    the residual structure."""

    theta: np.ndarray
    base_fit: float
    base_held: float
    n_eff_fit: float          # of the base model's residuals
    n_eff_held: float
    ranking: list[Candidate]
    floor: Candidate          # θ̂ -> θ̃: explained = 1 - E_H(θ̃)/E_H(θ̂)
    verdict: str
    found: Candidate | None
    structure: dict[str, Any] = field(default_factory=dict)
    pair: dict[str, Any] | None = None    # the two best refined together (module docstring, step 3)
    alternatives: list[str] = field(default_factory=list)   # effects the evidence cannot tell from the found one
    contest: dict[str, Any] | None = None  # the contenders and their common effective counts (:func:`_contest`)
    replication: dict[str, Any] | None = None   # {"effect", "gains", "replicated"[, "refit"]} of the top effect

    def table(self) -> str:
        """The ranking as text: effect, evidence above the floor, explained fraction, fitted size."""
        lines = [f"{'rank':>4}  {'effect':24s} {'evidence':>10} {'explained':>10}  estimate",
                 f"{'':>4}  {'floor: ' + self.floor.name:24s} {self.floor.evidence:10.1f} "
                 f"{self.floor.explained:10.1%}  {len(self.floor.values)} parameters moved"]
        for k, c in enumerate(self.ranking, 1):
            mark = " <- found" if self.found is not None and c.name == self.found.name else ""
            lines.append(f"{k:>4}  {c.name:24s} {c.evidence:10.1f} {c.explained:10.1%}  {values_text(c.values)}"
                         f"{place_text(c)}{mark}")
        if self.contest is not None:
            lines.append(f"      contenders {', '.join(self.contest['effects'])}: scored with common "
                         f"K_F = {self.contest['n_fit']:.1f}, K_H = {self.contest['n_held']:.1f}")
        if self.alternatives:
            lines.append(f"      indistinguishable by evidence from the found effect: {', '.join(self.alternatives)}")
        if self.replication is not None and self.replication["gains"]:
            gains = ", ".join(f"{g} {v:+.1%}" for g, v in self.replication["gains"].items())
            refitted = "refit" in self.replication        # run only when the check with θ̃ held failed
            verdict = " -> does not replicate" if refitted or not self.replication["replicated"] else ""
            lines.append(f"      {self.replication['effect']} fitted without each fit trajectory, its gain there: "
                         f"{gains}{verdict}")
            if refitted:
                refit = ", ".join(f"{g} {v:+.1%}" for g, v in self.replication["refit"].items())
                lines.append(f"      refitted with the model's parameters as well: {refit} -> "
                             f"{'replicates' if self.replication['replicated'] else 'does not replicate'}")
        if self.pair is not None:
            a, b = self.pair["effects"]
            given = self.pair["given"]
            lines.append(f"      pair {a} + {b}: explains {self.pair['explained']:.1%}; evidence of {a} given {b} "
                         f"{given[a]:.1f}, of {b} given {a} {given[b]:.1f}")
        return "\n".join(lines)

    def as_dict(self) -> dict[str, Any]:
        """A JSON-able record of the criticism."""
        return {"verdict": self.verdict, "found": None if self.found is None else asdict(self.found),
                "floor": asdict(self.floor), "ranking": [asdict(c) for c in self.ranking],
                "base_fit": self.base_fit, "base_held": self.base_held, "n_eff_fit": self.n_eff_fit,
                "n_eff_held": self.n_eff_held, "structure": self.structure, "pair": self.pair,
                "alternatives": self.alternatives, "contest": self.contest, "replication": self.replication}


def polish(objective: Objective, theta: np.ndarray, fit: np.ndarray, config: CriticismConfig = CriticismConfig(),
           indices: Sequence[int] | None = None) -> LocalFit:
    """Re-tune the parameters ``indices`` (default all) on the fit segments by bounded least
    squares (belief.least_squares; the fit error never rises): θ̃ (D,), its parts (S,) and residuals."""
    indices = range(objective.space.dim) if indices is None else indices
    return least_squares.refine(objective, np.asarray(theta, float), indices, fit, config.local)


def _screen(objective: EffectObjective, theta: np.ndarray, parts: np.ndarray, effect: Effect, fit: np.ndarray,
            held: np.ndarray, config: CriticismConfig) -> Candidate:
    """The effect's parameters fitted on F with θ̃ held, scored against θ̃."""
    extended, start, indices = effect_start(objective, theta, effect)
    fitted, eparts = fit_effect(extended, start, indices, fit, grid=config.grid, refine=config.refine)
    values = {extended.space.names[j]: float(fitted[j]) for j in indices}
    k_fit, k_held = (effective_counts(extended.residuals(fitted), fit, held) if np.isfinite(eparts).all()
                     else (math.nan, math.nan))
    before = (float(parts[fit].sum()), float(parts[held].sum()))
    c = scored(effect.name, "effect", values, eparts, fit, held, before, k_fit, k_held, len(indices),
                   effect.config())
    return replace(c, theta=tuple(float(v) for v in fitted))


def _screen_placed(objective: EffectObjective, theta: np.ndarray, parts: np.ndarray, effect: Effect,
                   fit: np.ndarray, held: np.ndarray, config: CriticismConfig) -> Candidate:
    """The effect screened at each of its m placements (Effect.placements); the best by evidence,
    charged 2 ln m."""
    options = effect.placements()
    rows = [_screen(objective, theta, parts, p, fit, held, config) for p in options]
    best = max(rows, key=lambda c: c.evidence)
    return rescore(replace(best, placements=len(options)), (float(parts[fit].sum()), float(parts[held].sum())))


def _with(objective: EffectObjective, *candidates: Candidate) -> EffectObjective:
    """``objective`` with the effects of ``candidates`` (rebuilt from their configs) added to its own."""
    return objective.with_effects(tuple(objective.effects) + tuple(effect_from_config(c.config) for c in candidates))


def _joint(objective: EffectObjective, c: Candidate, fit: np.ndarray, held: np.ndarray, base: tuple[float, float],
           config: CriticismConfig) -> Candidate:
    """A screened effect refined jointly with the model's parameters from (θ̃, η̂); scored against
    the base after its own second refinement."""
    if not np.isfinite(c.evidence):
        return c
    extended = _with(objective, c)
    D = objective.space.dim
    result = polish(extended, np.asarray(c.theta), fit, config)
    theta, parts = result.theta, result.parts
    if not np.isfinite(parts).all():
        return rescore(c, base)
    k_fit, k_held = effective_counts(result.residuals, fit, held)
    values = {extended.space.names[j]: float(theta[j]) for j in range(D, extended.space.dim)}
    out = scored(c.name, "effect", values, parts, fit, held, base, k_fit, k_held, len(values), c.config,
                     c.placements)
    return replace(out, stage="joint", theta=tuple(float(v) for v in theta))


def _pair(objective: EffectObjective, a: Candidate, b: Candidate, fit: np.ndarray, held: np.ndarray,
          base: tuple[float, float], config: CriticismConfig) -> dict[str, Any] | None:
    """``a`` and ``b`` (joint fits) refined together from a's θ and b's η; the pair's held-out
    explained fraction against ``base`` and each member's evidence given the other (module docstring)."""
    extended = _with(objective, a, b)
    start = np.r_[np.asarray(a.theta, float), np.asarray(b.theta, float)[objective.space.dim:]]
    result = polish(extended, start, fit, config)
    theta, parts = result.theta, result.parts
    if not np.isfinite(parts).all():
        return None
    k_fit, k_held = effective_counts(result.residuals, fit, held)
    given = {}
    for member, other in ((a, b), (b, a)):
        c = scored(member.name, "effect", member.values, parts, fit, held, (other.fit_error, other.held_error),
                       k_fit, k_held, len(member.values), member.config, member.placements)
        given[member.name] = c.evidence
    names = extended.space.names
    return {"effects": [a.name, b.name], "given": given, "explained": 1.0 - float(parts[held].sum()) / base[1],
            "fit_error": float(parts[fit].sum()), "held_error": float(parts[held].sum()),
            "values": {names[j]: float(theta[j]) for j in range(objective.space.dim, len(names))}}


def _passes(c: Candidate, config: CriticismConfig) -> bool:
    return c.evidence >= config.min_evidence and c.explained >= config.min_fraction


def _contest(ranking: list[Candidate], base: tuple[float, float],
             config: CriticismConfig) -> tuple[list[Candidate], dict[str, Any] | None]:
    """The effects that would each be found (contenders), scored with common effective counts.

    Each contender's evidence is a sum of K ln(E_0/E_e) terms with its own effective count K: between
    two effects that both explain the residual, a difference of K (an estimate from each one's
    residuals) would decide their order, not their fit. So all are scored with K̄_F, K̄_H, the
    means of their counts:

        evidence_e = K̄_F ln(E_F / E_F,e) + K̄_H ln(E_H / E_H,e) - k_e ln(K̄_F + K̄_H)

    whose difference between contenders a and b is K̄_F ln(E_F,b/E_F,a) + K̄_H ln(E_H,b/E_H,a)
    - (k_a - k_b) ln(K̄_F + K̄_H), twice a log-likelihood ratio on the same data. Returns the
    ranking with the contenders rescored, and {"effects", "n_fit", "n_held"} (None: fewer than two)."""
    names = [c.name for c in ranking if _passes(c, config) and c.theta]
    if len(names) < 2:
        return ranking, None
    contenders = [c for c in ranking if c.name in names]
    k_fit = float(np.mean([c.n_fit for c in contenders]))
    k_held = float(np.mean([c.n_held for c in contenders]))
    common = {c.name: rescore(replace(c, n_fit=k_fit, n_held=k_held), base) for c in contenders}
    return [common.get(c.name, c) for c in ranking], {"effects": names, "n_fit": k_fit, "n_held": k_held}


def _order(ranking: list[Candidate], config: CriticismConfig) -> list[Candidate]:
    """By evidence, best first, except that the effects within ``tie`` of the best evidence that
    would each be found come before those that would not (module docstring, step 3)."""
    ranking = sorted(ranking, key=lambda c: -c.evidence)
    if not ranking or not np.isfinite(ranking[0].evidence):
        return ranking
    close = [c for c in ranking if c.evidence >= ranking[0].evidence - config.tie and _passes(c, config)]
    return close + [c for c in ranking if c not in close]


def _replicates(objective: EffectObjective, crit: Criticism, fit: np.ndarray, config: CriticismConfig) -> bool:
    """Whether the top effect replicates across the fit trajectories (criticism.replication), with θ̃
    held or, where that fails for an effect that passes both bars, refitted; records the gains in
    crit.replication. True when the check is off or has fewer than two groups."""
    if config.min_replication is None:
        return True
    top = crit.ranking[0]
    effect, bar = effect_from_config(top.config), config.min_replication
    gains = replication_gains(objective, crit.theta, effect, fit, grid=config.grid, refine=config.refine)
    replicated = all(g >= bar for g in gains.values())
    crit.replication = {"effect": top.name, "gains": gains, "replicated": replicated}
    if not replicated and config.refit_replication and top.stage == "joint" and _passes(top, config):
        refit = refit_replication_gains(objective, crit.theta, np.asarray(top.theta, float), effect, fit, config.local)
        replicated = all(g >= bar for g in refit.values())
        crit.replication.update(refit=refit, replicated=replicated)
    return replicated


def _verdict(objective: EffectObjective, crit: Criticism, fit: np.ndarray, held: np.ndarray,
             config: CriticismConfig) -> Criticism:
    """Set crit.verdict and crit.found (module docstring, step 3), trying the pair when no single
    effect suffices; the top effect's replication is measured whenever its evidence is positive
    (the table reports it), and it must replicate to be found."""
    ranking = crit.ranking
    if not ranking or not ranking[0].evidence > 0:
        return crit
    top = ranking[0]
    replicated = _replicates(objective, crit, fit, config)
    if _passes(top, config):
        if replicated:
            crit.verdict, crit.found = "found", top
            best = max(c.evidence for c in ranking)
            crit.alternatives = [c.name for c in ranking[1:] if c.evidence >= best - config.tie]
    elif len(ranking) > 1 and all(c.stage == "joint" for c in ranking[:2]):
        crit.pair = _pair(objective, ranking[0], ranking[1], fit, held, (crit.base_fit, crit.base_held), config)
        if (crit.pair is not None and min(crit.pair["given"].values()) >= config.min_evidence
                and crit.pair["explained"] >= config.min_fraction and replicated):
            crit.verdict, crit.found = "found", top
    return crit


def criticize(objective: EffectObjective, theta: np.ndarray, *, fit: np.ndarray | Sequence[bool],
              held: np.ndarray | Sequence[bool], effects: Sequence[Effect], config: CriticismConfig = CriticismConfig(),
              structure: dict[str, Any] | None = None, progress: bool = True) -> Criticism:
    """Rank ``effects`` (physics.effects instances not in ``objective.effects``) as explanations of
    the residual of ``objective`` at θ̂ (D,) (module docstring). ``fit``, ``held``: masks (S,)
    over ``objective.segments``, disjoint and non-empty; the objective's loss must be "squared"."""
    fit_mask, held_mask = np.asarray(fit, bool), np.asarray(held, bool)
    S = len(objective.segments)
    if (fit_mask.shape != (S,) or held_mask.shape != (S,) or not fit_mask.any() or not held_mask.any()
            or (fit_mask & held_mask).any()):
        raise CriticismError(f"fit and held must be disjoint, non-empty boolean masks over the {S} segments "
                             f"{list(objective.segments)}.")
    if objective.loss != "squared":
        raise CriticismError("criticism needs a sum-of-squares objective (TrajectoryObjective(..., loss='squared')): "
                             "its evidence is a Gaussian likelihood ratio.")
    present = {e.name for e in objective.effects}
    effects = [e.bind(objective.trajectories) for e in effects if e.name not in present]    # sizes seen at rest
    start = np.asarray(theta, float)
    start_parts = np.asarray(objective.evaluate_parts(start), float)
    result = polish(objective, start, fit_mask, config)
    screened = [_screen_placed(objective, result.theta, result.parts, e, fit_mask, held_mask, config)
                for e in tqdm(effects, desc="effects", leave=False, disable=not progress)]
    if config.joint > 0 and screened:   # a second refinement for the base too, so both get the same search
        result = polish(objective, result.theta, fit_mask, config)
    theta, parts = result.theta, result.parts
    n_fit, n_held = effective_counts(result.residuals, fit_mask, held_mask)
    base = (float(parts[fit_mask].sum()), float(parts[held_mask].sum()))
    moved = {n: float(v) for n, v, v0 in zip(objective.space.names, theta, start, strict=True) if v != v0}
    start_base = (float(start_parts[fit_mask].sum()), float(start_parts[held_mask].sum()))
    floor = scored("re-tuned model", "floor", moved, parts, fit_mask, held_mask, start_base, n_fit, n_held,
                       len(moved), {})
    screened.sort(key=lambda c: -c.evidence)
    top = tqdm(screened[:config.joint], desc="joint fits", leave=False, disable=not progress)
    ranking = [_joint(objective, c, fit_mask, held_mask, base, config) for c in top]
    ranking, contest = _contest(ranking + [rescore(c, base) for c in screened[config.joint:]], base, config)
    crit = Criticism(theta, base[0], base[1], n_fit, n_held, _order(ranking, config), floor, "unexplained", None,
                     dict(structure or {}), contest=contest)
    return _verdict(objective, crit, fit_mask, held_mask, config)
