"""From the evaluations to a :class:`~belief.belief.Belief`: σ², P, segment posteriors, verdicts.

::

    1  σ²: given, else the objective's known noise, else the noise rule (belief.noise) on the
       residuals of the best evaluated θ (one extra evaluation of the objective)
    2  P over the cells from the GP fitted to all evaluations (belief.posterior)
    3  the verified mass of P: Σ P where the GP knows the log-likelihood to 1 nat (belief.verdicts);
       with an estimated σ², P floors E at the best evaluated error (belief.posterior), so no cell
       outweighs the best evaluation
    4  one posterior per segment of E (time windows, trajectories) from a GP fitted to that
       segment's errors, with that segment's own σ²; disjoint narrow intervals = conflict
    5  marginals of P and a verdict per parameter (belief.verdicts.decide)
    6  if any parameter is (weakly) identified: the Jacobian over all parameters at the best
       evaluated θ and one Gauss-Newton step (D + 4 evaluations, D + 3 when step 1 evaluated the
       residuals there); a much better fit outside a parameter's interval, or a local std wider
       than P's, withdraws its verdict (the "local refit" and "local width" rules of
       belief.verdicts); the local std also spreads the best cell's mass in the marginals
       (belief.spread), so a P on one cell still gets the data's width
    7  parameters the data narrow whose fitted θ (the step's θ′, else the best evaluated θ) sits at
       a bound of the box are not identified and listed in attrs["at_bounds"] (the "at bound"
       rule, belief.bounds)

Objectives without residuals (``residuals`` raises :class:`~physics.errors.NoResidualsError`, as
a wrapped plain function does) fall back to the "iid" rule and skip step 6; objectives with one
segment skip step 4. Both are recorded in the Belief's attrs, as are σ², K, K_eff, the budget warning, E's floor
(``error_floor``), P of the best evaluated cell (``best_cell_mass``) and, when P cannot be trusted
(an interval that excludes the best evaluation, little verified mass), why (``trust``,
belief.verdicts.trust_note; the summary prints it).

Evaluations: the assessment evaluates E after the search (step 1's residuals, step 6's
Gauss-Newton step, the "calibrated" rule's fit); attrs["evaluations"] counts them. A run that ends
with a Gauss-Newton step (``finish_step``, belief.presets) takes it here from the best evaluation,
so that it shares those evaluations: the calibrated fit when it ran, else step 6's step when it
ran, else one step of its own from step 1's residuals; attrs["finishing_step"] records it and
:func:`finishing_cost` bounds all of them, which is what such a run's budget keeps for them.
"""
from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from belief.belief import Belief
from belief.bounds import AtBound, at_bounds
from belief.counting import CountingObjective
from belief.errors import BeliefError, BudgetWarning
from belief.grid import CandidateSet
from belief.journal import Record
from belief.least_squares import (
    DEFAULT_FIT,
    DEFAULT_STEP,
    FitConfig,
    LocalStep,
    StepConfig,
    gauss_newton_fit,
    gauss_newton_step,
)
from belief.noise import iid_noise_var, noise_var_from_residuals, segment_discrepancy
from belief.posterior import PosteriorConfig, marginals, posterior_from_surrogate
from belief.scale import ScaleConfig, calibrated_scale
from belief.spread import CellSpread
from belief.surrogate import GPSurrogate, SurrogateConfig
from belief.verdicts import (
    VerdictConfig,
    because,
    budget_warning,
    decide,
    loglik_sd,
    pinned,
    refit_conflicts,
    segment_conflicts,
    trust_note,
    verified_mass,
)
from embeddings.base import Decoder
from physics.errors import NoResidualsError, PhysicsError
from physics.objective import Objective
from physics.parameters import ParameterSpace

__all__ = ["NoiseLevel", "noise_level", "assess", "fits_to_convergence", "finishing_cost", "step_record"]

_KNOWN = ("given", "known by the objective")


@dataclass(frozen=True)
class NoiseLevel:
    """σ² of the whole E and of each segment (None in minimizer mode), with how it was set;
    ``best_residuals``: the residuals at the best evaluated θ when the rule evaluated them (S
    arrays), which the Gauss-Newton steps from there reuse instead of evaluating them again."""

    total: float | None
    segments: tuple[float, ...] = ()
    rule: str = ""
    info: dict[str, Any] = field(default_factory=dict)
    best_residuals: tuple[np.ndarray, ...] | None = field(default=None, compare=False, repr=False)

    @property
    def known(self) -> bool:
        """σ² was given or declared by the objective, not estimated from the evaluations."""
        return self.rule in _KNOWN


def _residuals(objective: Objective, theta: np.ndarray) -> list[np.ndarray] | None:
    """The residuals at θ, or None when the objective has none or the simulation diverged."""
    try:
        return [np.asarray(r, dtype=float) for r in objective.residuals(theta)]
    except (NoResidualsError, PhysicsError):
        return None


def noise_level(objective: Objective, config: PosteriorConfig, errors: np.ndarray, parts: np.ndarray,
                best_theta: np.ndarray, *, dim: int, fit: LocalFinish | None = None) -> NoiseLevel:
    """σ² of E and of each of its S segments (step 1 of the module docstring).

    ``errors``: E of the successful evaluations (n,); ``parts``: their segment errors (n x S);
    ``fit``: the local fit, which the "calibrated" rule needs (without one it falls back to "ess").
    """
    S = parts.shape[1]
    if config.mode != "likelihood":
        return NoiseLevel(None, (), "none (minimizer mode)")
    given = config.noise_var if config.noise_var is not None else objective.noise_var
    if given is not None:
        rule = _KNOWN[0] if config.noise_var is not None else _KNOWN[1]
        return NoiseLevel(float(given), (float(given),) * S, rule)
    if config.noise_rule == "calibrated" and fit is not None and len(fit.residuals) == S:
        scale = calibrated_scale(fit.residuals, fit.step.jacobian, noise_floor=objective.noise_floor,
                                 config=ScaleConfig(discrepancy=config.discrepancy),
                                 least=1e-12 * float(np.nanmedian(errors)))
        segs = tuple(max(scale.blocks_var, 0.5 * scale.discrepancy * float(np.nansum(r ** 2)), 1e-300)
                     for r in fit.residuals)
        return NoiseLevel(scale.noise_var, segs, "calibrated", scale.as_dict())
    K = int(objective.n_observations)
    res = _residuals(objective, best_theta) if config.noise_rule in ("ess", "calibrated") else None
    if res is None or len(res) != S:
        why = "iid" if config.noise_rule == "iid" else "iid (the objective gives no residuals per segment)"
        total = iid_noise_var(errors, n_observations=K, dim=dim)
        segs = tuple(iid_noise_var(parts[:, s], n_observations=max(K // S, 1), dim=dim) for s in range(S))
        start = tuple(res) if res is not None and len(res) == len(objective.segments) else None   # the steps'
        return NoiseLevel(total, segs, why, {"n_observations": K}, start)
    d_seg = segment_discrepancy(parts)
    delta = max(config.discrepancy, d_seg)
    total, size = noise_var_from_residuals(errors, res, dim=dim, discrepancy=delta)
    segs = tuple(noise_var_from_residuals(parts[:, s], [res[s]], dim=dim, discrepancy=delta)[0] for s in range(S))
    return NoiseLevel(total, segs, "ess", {"n_observations": size.n, "n_effective": size.n_eff,
                                          "tau": list(size.tau), "coords": list(size.coords),
                                          "discrepancy": delta, "segment_discrepancy": d_seg}, tuple(res))


@dataclass(frozen=True)
class LocalFinish:
    """The local fit from the best evaluation: its end point and Jacobian there (``step``), the
    residuals there (S arrays), and the record for the Belief's attrs["local_fit"]."""

    step: LocalStep
    residuals: list[np.ndarray]
    info: dict[str, Any]


def local_finish(objective: Objective, best_theta: np.ndarray | Sequence[float], config: FitConfig = DEFAULT_FIT
                 ) -> tuple[LocalFinish | None, dict[str, Any]]:
    """Gauss-Newton to convergence from the best evaluated θ (belief.least_squares.gauss_newton_fit), or
    None and why (no residuals; a simulation that diverged is reported there, not hidden)."""
    try:
        step, residuals = gauss_newton_fit(objective, np.asarray(best_theta, dtype=float), config)
    except NoResidualsError:
        return None, {"skipped": "the objective gives no residuals"}
    except (BeliefError, PhysicsError) as exc:
        return None, {"skipped": str(exc)}
    info: dict[str, Any] = {"theta": [float(v) for v in step.theta], "error": step.error,
                            "start_error": step.start_error, "evaluations": step.evaluations, "converged_fit": True}
    return LocalFinish(step, [np.asarray(r, dtype=float) for r in residuals], info), info


def _segment_marginals(records: Sequence[Record], grid: CandidateSet, theta_cells: np.ndarray, space: ParameterSpace,
                       segments: Sequence[str],
                       parts: np.ndarray, noise: NoiseLevel, failed: np.ndarray, *, surrogate: SurrogateConfig,
                       config: PosteriorConfig, seed: int) -> dict[str, xr.Dataset]:
    """Marginals of P_s per segment s (step 4), from a GP on that segment's errors (``parts`` n x S)."""
    Z = np.array([r.z for r in records], dtype=float)
    out = {}
    for s, name in enumerate(segments):
        model = GPSurrogate(grid.bounds, config=surrogate).fit(Z, parts[:, s])
        nv = noise.segments[s] if noise.segments else None
        P_s = posterior_from_surrogate(model, grid, config=config, noise_var=nv, failed=failed, seed=seed + s + 1,
                                       noise_known=noise.known)
        out[name] = marginals(P_s, theta_cells, space, level=config.level, identified_ratio=config.identified_ratio)
    return out


def fits_to_convergence(objective: Objective, config: PosteriorConfig | None) -> bool:
    """Whether the assessment fits by Gauss-Newton to convergence (the "calibrated" noise rule with σ²
    neither given nor known by the objective) rather than taking at most one step."""
    return (config is not None and config.mode == "likelihood" and config.noise_var is None
            and objective.noise_var is None and config.noise_rule == "calibrated")


def finishing_cost(dim: int, step: StepConfig, *, converges: bool, fit: FitConfig = DEFAULT_FIT) -> int:
    """The most evaluations of E an assessment with a finishing step (module docstring) spends in a D =
    ``dim`` space: the fit's (``converges``, :func:`fits_to_convergence`), else one step's, whose
    start is step 1's residuals."""
    return fit.cost(dim) if converges else step.cost(dim)


def step_record(objective: Objective, theta: np.ndarray | Sequence[float], config: StepConfig = DEFAULT_STEP, *,
                start: Sequence[np.ndarray] | None = None) -> tuple[LocalStep | None, dict[str, Any]]:
    """One Gauss-Newton step of all parameters from θ (belief.least_squares.gauss_newton_step; ``start``:
    the residuals at θ when already evaluated) and its record: θ′, E(θ′), E(θ), evaluations, or why
    it was not taken (no residuals; a diverged simulation is reported there, not hidden)."""
    try:
        step = gauss_newton_step(objective, np.asarray(theta, dtype=float), config, start=start)
    except NoResidualsError:
        return None, {"skipped": "the objective gives no residuals"}
    except (BeliefError, PhysicsError) as exc:
        return None, {"skipped": str(exc)}
    return step, {"theta": [float(v) for v in step.theta], "error": step.error, "start_error": step.start_error,
                  "evaluations": step.evaluations}


def _local_fit(objective: Objective, best_theta: np.ndarray | Sequence[float], noise: NoiseLevel, config: StepConfig
               ) -> tuple[LocalStep | None, np.ndarray | None, dict[str, Any]]:
    """(step, local std (D,) or None, info) of one Gauss-Newton step of all parameters from the best
    evaluated θ (:func:`step_record`, from step 1's residuals when it evaluated them), for the "local
    refit" and "local width" rules (belief.verdicts) and the best cell's spread (belief.spread).

    ``info`` goes to the Belief's attrs["local_fit"]: θ′, E(θ′), E(θ̂), evaluations and the local
    std, or why the step was not taken.
    """
    step, info = step_record(objective, best_theta, config, start=noise.best_residuals)
    if step is None:
        return None, None, info
    std = None
    if noise.total is not None:
        std = step.laplace_std(noise.total)
        info["std"] = [float(v) for v in std]
    return step, std, info


def _pinned(space: ParameterSpace, best_theta: np.ndarray | Sequence[float], local: dict[str, Any], marg: xr.Dataset,
            cfg: VerdictConfig, ratio: np.ndarray | None) -> tuple[AtBound, ...]:
    """The "at bound" rule (belief.verdicts): parameters the data narrow at a bound of the fitted θ, which is the
    local fit's θ′ when the step moved (its best point), else the best evaluated θ."""
    best = np.asarray(best_theta, dtype=float)
    fitted, source = best, "best evaluation"
    if "theta" in local and not np.array_equal(np.asarray(local["theta"], dtype=float), best):
        fitted, source = np.asarray(local["theta"], dtype=float), "local fit"
    found = at_bounds(space, fitted, tolerance=cfg.bound_tolerance, source=source)
    return pinned(marg, found, weak_ratio=cfg.weak_ratio, local_ratio=ratio)


@dataclass(frozen=True)
class _Refinement:
    """What the local fit at the best evaluation adds: the marginals with that cell spread by its
    Laplace std, the fit's record, conflicts between fit and marginals, and std / (width / √12)."""
    marg: xr.Dataset
    local: dict[str, Any]
    conflicts: dict[str, str] = field(default_factory=dict)
    ratio: np.ndarray | None = None
    spread: CellSpread | None = None


def _refine(objective: Objective, best: Record, noise: NoiseLevel, P: xr.DataArray, theta_cells: np.ndarray,
            space: ParameterSpace, *, config: PosteriorConfig, vcfg: VerdictConfig, marg: xr.Dataset,
            step_config: StepConfig) -> _Refinement:
    """Gauss-Newton at the best evaluation (:func:`_local_fit`): spread its cell by the local std
    s_j (ratio s_j / (cell width_j / √12)) and flag parameters the step moves beyond the marginals."""
    step, std, local = _local_fit(objective, best.theta, noise, step_config)
    ratio, spread = None, None
    if std is not None and step is not None:
        ratio = std / np.maximum(step.width / np.sqrt(12.0), 1e-300)
        spread = CellSpread(best.cell, tuple(std))
        marg = marginals(P, theta_cells, space, level=config.level, identified_ratio=config.identified_ratio,
                         spread=spread)
    conflicts: dict[str, str] = {}
    if step is not None:
        conflicts = refit_conflicts(marg, step.theta, step.error, step.start_error, noise_var=noise.total,
                                    nats=vcfg.refit_nats, fraction=vcfg.refit_fraction)
    return _Refinement(marg, local, conflicts, ratio, spread)


def _centred(fit: LocalFinish, cell: int, noise_var: float, P: xr.DataArray, theta_cells: np.ndarray,
             space: ParameterSpace, *, config: PosteriorConfig) -> _Refinement:
    """The best cell's mass as the local posterior of the fit that ran from it: N(θ̂, σ² (JᵀJ)⁻¹)
    truncated to the box, θ̂ the fit's end point (belief.spread); its local std also gives the
    "local width" ratio. The fit is the minimum the interval is centred on, so no "local refit"
    conflict can arise."""
    std = fit.step.laplace_std(noise_var)
    spread = CellSpread(cell, tuple(std), tuple(fit.step.theta), tuple(map(tuple, fit.step.draw_cov(noise_var))))
    marg = marginals(P, theta_cells, space, level=config.level, identified_ratio=config.identified_ratio, spread=spread)
    info = {**fit.info, "std": [float(v) for v in std]}
    return _Refinement(marg, info, {}, std / np.maximum(fit.step.width / np.sqrt(12.0), 1e-300), spread)


def _refinement(objective: Objective, best: Record, fit: LocalFinish | None, fit_info: dict[str, Any],
                noise: NoiseLevel, P: xr.DataArray, theta_cells: np.ndarray, space: ParameterSpace,
                verdicts: Sequence[str], *, config: PosteriorConfig, vcfg: VerdictConfig, marg: xr.Dataset,
                step_config: StepConfig) -> tuple[_Refinement, np.ndarray, bool]:
    """Step 6: (refinement, the fitted θ, whether step 6 took its Gauss-Newton step). The calibrated
    fit centres the best cell when it ran; else the step runs when a parameter narrowed."""
    fitted = np.asarray(best.theta, dtype=float)
    if fit is not None and noise.total is not None:
        return _centred(fit, best.cell, noise.total, P, theta_cells, space, config=config), fit.step.theta, False
    if vcfg.refit and any(v != "not identified" for v in verdicts):
        return _refine(objective, best, noise, P, theta_cells, space, config=config, vcfg=vcfg, marg=marg,
                       step_config=step_config), fitted, True
    if fit_info:
        return _Refinement(marg, fit_info), fitted, False
    why = "no parameter narrowed" if vcfg.refit else "VerdictConfig.refit is off"
    return _Refinement(marg, {"skipped": why}), fitted, False


def _finishing(objective: Objective, best_theta: Sequence[float], noise: NoiseLevel, fit: LocalFinish | None,
               local: dict[str, Any], stepped: bool, step_config: StepConfig) -> dict[str, Any]:
    """The record of the finishing step (module docstring): the calibrated fit when it ran, else step
    6's step when it was taken (``stepped``), else one step taken now from step 1's residuals."""
    if fit is not None:
        return dict(fit.info)
    if stepped:
        return {k: v for k, v in local.items() if k != "std"}
    return step_record(objective, best_theta, step_config, start=noise.best_residuals)[1]


def assess(objective: Objective, decoder: Decoder, grid: CandidateSet, records: Sequence[Record], model: GPSurrogate, *,
           config: PosteriorConfig, surrogate: SurrogateConfig, seed: int,
           verdict_config: VerdictConfig | None = None, fit_config: FitConfig = DEFAULT_FIT,
           finish_step: StepConfig | None = None, reserved: int = 0) -> Belief:
    """The Belief of an identification run (module docstring).

    ``records``: every evaluation (journal Records, ``status`` "ok" for successes, ``parts`` per
    segment); ``model``: the GP fitted to all evaluations; ``seed``: minimizer-mode sampling;
    ``fit_config``: the local fit of the "calibrated" noise rule; ``finish_step``: the Gauss-Newton
    step that ends the run, taken here (module docstring), or None; ``reserved``: the evaluations
    of the run's budget kept for this assessment (belief.search), which the budget warning adds.
    """
    vcfg = verdict_config or VerdictConfig(identified_ratio=config.identified_ratio)
    ok = [r for r in records if r.status == "ok"]
    if len(ok) < 2:
        raise BeliefError(f"only {len(ok)} successful evaluation(s); the posterior needs at least 2.")
    counted = CountingObjective(objective)
    space = decoder.space
    errors = np.array([r.error for r in ok])
    best = ok[int(np.argmin(errors))]
    segments = tuple(objective.segments)
    whole = bool(segments) and all(len(r.parts) == len(segments) for r in ok)
    parts = np.array([r.parts for r in ok], dtype=float) if whole else errors[:, None]
    if parts.shape[1] != len(segments):
        segments = ("all",)
    converges = fits_to_convergence(objective, config)
    fit, fit_info = local_finish(counted, best.theta, fit_config) if converges else (None, {})
    noise = noise_level(counted, config, errors, parts, np.asarray(best.theta), dim=decoder.dim, fit=fit)
    failed = np.zeros(grid.size, dtype=bool)
    failed[[r.cell for r in records if r.status != "ok"]] = True
    pred = model.predict(grid.points)
    P = posterior_from_surrogate(model, grid, config=config, noise_var=noise.total, failed=failed, seed=seed,
                                 prediction=pred, noise_known=noise.known)
    p = P.values.ravel()
    theta_cells = decoder.decode(np.asarray(grid.points))
    vmass = 1.0
    if noise.total is not None:
        vmass = verified_mass(p, loglik_sd(*pred, shift=model.shift_, noise_var=noise.total), max_sd=vcfg.max_loglik_sd)
    conflicts: dict[str, str] = {}
    if len(segments) >= 2:
        seg = _segment_marginals(ok, grid, theta_cells, space, segments, parts, noise, failed, surrogate=surrogate,
                                 config=config, seed=seed)
        conflicts = segment_conflicts(seg, identified_ratio=vcfg.identified_ratio)
    marg = marginals(P, theta_cells, space, level=config.level, identified_ratio=config.identified_ratio)
    verdicts, reasons = decide(marg, best_theta=best.theta, verified=vmass, conflicts=conflicts, config=vcfg)
    refined, fitted, stepped = _refinement(counted, best, fit, fit_info, noise, P, theta_cells, space, verdicts,
                                           config=config, vcfg=vcfg, marg=marg,
                                           step_config=finish_step or DEFAULT_STEP)
    marg, local, extra, ratio, spread = refined.marg, refined.local, refined.conflicts, refined.ratio, refined.spread
    at_bound = _pinned(space, best.theta, local, marg, vcfg, ratio)
    verdicts, reasons = decide(marg, best_theta=fitted, verified=vmass, config=vcfg, local_ratio=ratio,
                               reduced=decoder.dim < space.dim,
                               conflicts={**extra, **conflicts,
                                          **{a.name: because("at bound", a.reason()) for a in at_bound}})
    best_mass = float(p[best.cell])
    trust = trust_note(marg, verdicts, best_theta=fitted, verified=vmass, best_mass=best_mass, config=vcfg,
                       local_ratio=ratio)
    finishing = None if finish_step is None else _finishing(counted, best.theta, noise, fit, local, stepped,
                                                            finish_step)
    warn = budget_warning(len(ok), decoder.dim, per_dim=vcfg.evaluations_per_dim, failed=len(records) - len(ok),
                          reserved=reserved)
    if warn:
        warnings.warn(warn, BudgetWarning, stacklevel=3)
    attrs = {"mode": config.mode, "level": config.level, "noise_var": noise.total, "noise_rule": noise.rule,
             "noise": noise.info, "segments": list(segments), "verified_mass": vmass, "n_evaluations": len(records),
             "n_successful": len(ok), "best_error": float(best.error), "budget_warning": warn, "local_fit": local,
             "at_bounds": [a.as_dict() for a in at_bound], "bound_tolerance": vcfg.bound_tolerance,
             "error_floor": P.attrs.get("error_floor"), "best_cell_mass": best_mass, "trust": trust,
             "assessment_evaluations": counted.evaluations}
    if finishing is not None:
        attrs["finishing_step"] = finishing
    return Belief(P, theta_cells, space, decoder_config=decoder.config(), grid_config=grid.config(),
                  verdicts=verdicts, reasons=reasons, attrs=attrs, level=config.level, grid=grid, spread=spread)
