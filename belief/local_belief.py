"""P at the data's resolution: after the global search, Algorithm 1 on a grid zoomed onto the
directions the data pin.

A global grid cannot resolve what the data pin: a cell of 4096 Sobol points in the 15-D box is
tens of posterior widths across in rod_length. So the identification continues locally::

    1  local fits: Gauss-Newton to convergence from the ``starts`` best evaluations of the global
       search (belief.least_squares.gauss_newton_fit); the lowest end point is θ̂, with its
       Jacobian J (K x D, unit box) and residuals r; the grid is centred on the minimum of the
       quadratic approximation there (one regularized Newton step, with the measurements)
    2  the likelihood's scale σ² from r and J (belief.scale: block sandwich, adequacy against the
       noise floor the data show, the model-error floor only where the model falls short)
    3  the Fisher information F = JᵀJ/σ² in the unit box, its pinned part measured by E itself
       (belief.curvature: L at ± ``probe_sds`` posterior sds along, and between, the pinned
       directions, one batch; where E rises less than F says, F shrinks to what E shows). Its
       eigen-directions v_k (unit vectors) with eigenvalue λ_k: the uniform prior over the box
       spreads along v_k over the chord 1/max_j |v_kj| through the box's centre, variance
       1/(12 max_j v_kj²), so its precision there is π_k = 12 max_j v_kj², and a direction is
       pinned by the data when λ_k > π_k. Every parameter whose interval is under half the box is
       then profiled (belief.profile): where E, the others re-fitted, rises less at the interval's
       ends than the level asks, F widens to the profile's width. The ``dim``
       most pinned span the grid:
       w_k = v_k / sqrt(λ_k + π_k), one posterior sd (embeddings.LocalSubspace),
       ``points_per_dim`` points on [−span, span] each
    4  Algorithm 1 (GP + EI, belief.search) on that grid for ``budget`` evaluations (at most every
       cell), the centre
       first, P from the GP with the σ² of step 2 (belief.posterior, likelihood mode)
    5  the other directions keep their local posterior: every cell is spread by the normal with
       covariance Σ_⊥ = Σ_{k > dim} v_k v_kᵀ / (λ_k + π_k), truncated to the box
       (belief.spread.ComplementSpread): a direction the data do not see (λ_k ≪ π_k) keeps the
       box's spread along it, its prior (treating the prior's precision as diagonal in F's
       eigen-directions), and the grid's centre moves along these directions to their posterior
       mean, towards the box's middle by the prior's share of the precision (:func:`towards_prior`)
    6  marginals, intervals and ``Belief.sample`` from that P; verdicts (belief.verdicts): the
       narrowing against the box's prior, evaluated support, verified mass and the at-bound rule;
       what the data pin, named (belief.identifiability, from the same F), in the Belief's attrs.

Rules of the global belief that the calibrated scale makes unnecessary are not applied here: the
segments' disagreement is counted by the block sandwich (step 2) instead of the "segment
consistency" rule; the grid is centred on the local fit, so there is no "local refit"; the spread
of step 5 is the "local width"; the decoder spans the box's prior by construction ("reach").
When nothing is pinned (every λ_k ≤ 12) or the objective gives no residuals, the global belief
stands.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from belief.assess import LocalFinish, local_finish
from belief.belief import Belief
from belief.bounds import at_bounds
from belief.curvature import PRIOR_PRECISION, prior_precision, secant_information
from belief.errors import BeliefError
from belief.grid import Grid
from belief.identifiability import identifiability
from belief.least_squares import DEFAULT_FIT, FitConfig
from belief.posterior import PosteriorConfig, marginals, posterior_from_surrogate
from belief.profile import DEFAULT_PROFILE, ProfileConfig, profile_widths
from belief.proposers import BOProposer, SobolDesign, WarmStart, fit_surrogate
from belief.result import IdentificationResult
from belief.scale import Scale, ScaleConfig, calibrated_scale
from belief.search import search
from belief.spread import ComplementSpread
from belief.surrogate import SurrogateConfig
from belief.verdicts import VerdictConfig, because, decide, loglik_sd, pinned, verified_mass
from embeddings.local import LocalSubspace
from physics.measurements import MeasurementPrior
from physics.objective import Objective

__all__ = ["LocalConfig", "DEFAULT_LOCAL", "Directions", "NoLocalStage", "fisher_information", "directions_of",
           "pinned_directions", "towards_prior", "best_local_fit", "local_stage"]


class NoLocalStage(BeliefError):
    """The local stage cannot run here (its message says why); the global belief stands."""




@dataclass(frozen=True)
class LocalConfig:
    """dim: most pinned directions the grid spans; points_per_dim, span: the grid (cells ``2 span /
    (points_per_dim − 1)`` sds apart); budget: Algorithm 1's evaluations on it; starts: local fits
    from the best distinct evaluations; fit: each fit; scale: σ² (belief.scale); probe_sds: how far
    out E's curvature is measured (belief.curvature); profile: the profile-likelihood check of every
    narrow marginal (belief.profile), None to skip it."""

    dim: int = 4
    points_per_dim: int = 7
    span: float = 3.0
    budget: int = 20
    starts: int = 2
    fit: FitConfig = DEFAULT_FIT
    scale: ScaleConfig = field(default_factory=ScaleConfig)
    probe_sds: float = 2.0
    profile: ProfileConfig | None = DEFAULT_PROFILE

    def __post_init__(self) -> None:
        ints = {"dim": self.dim, "points_per_dim": self.points_per_dim, "budget": self.budget, "starts": self.starts}
        for name, value in ints.items():
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise BeliefError(f"LocalConfig.{name} must be an integer >= 1, got {value!r}.")
        if self.dim > 6 or self.points_per_dim < 3 or self.points_per_dim ** self.dim > 200_000:
            raise BeliefError(f"LocalConfig: a grid of {self.points_per_dim}^{self.dim} cells is too large or too "
                              "coarse; use dim <= 6, points_per_dim >= 3 and at most 200 000 cells.")
        for label, sds in {"span": self.span, "probe_sds": self.probe_sds}.items():
            if not (np.isfinite(sds) and sds > 0):
                raise BeliefError(f"LocalConfig.{label} must be a positive number of sds, got {sds!r}.")


#: the default local stage (frozen, so one instance serves as every default argument)
DEFAULT_LOCAL = LocalConfig()


@dataclass(frozen=True)
class Directions:
    """The eigen-directions of F = JᵀJ/σ² (unit box): ``values`` λ_k (descending), ``vectors`` (D x D,
    columns), ``grid`` the number spanned by the grid, ``basis`` (D x grid) the scaled directions,
    ``complement`` (D x D) Σ_⊥ in the unit box."""

    values: np.ndarray
    vectors: np.ndarray
    grid: int
    basis: np.ndarray
    complement: np.ndarray

    def covariance(self) -> np.ndarray:
        """The local posterior's covariance (D x D, unit box): Σ_k v_k v_kᵀ / (λ_k + π_k)."""
        return (self.vectors / (self.values + prior_precision(self.vectors))) @ self.vectors.T


def fisher_information(jacobian: np.ndarray, noise_var: float, prior_rows: np.ndarray | None = None) -> np.ndarray:
    """F = JᵀJ/σ² + GᵀG (D x D, unit box) from J (K x D) and, when given, the standardized rows G
    (M x D) of what the user measured (physics.measurements)."""
    J = np.nan_to_num(np.asarray(jacobian, dtype=float))
    F = J.T @ J / float(noise_var)
    if prior_rows is not None and np.size(prior_rows):
        G = np.asarray(prior_rows, dtype=float)
        F = F + G.T @ G
    return F


def directions_of(information: np.ndarray, *, dim: int, stretch: np.ndarray | None = None) -> Directions:
    """Steps 3 and 5 of the module docstring from an information matrix F (D x D, unit box);
    ``stretch`` (D,) ≥ 1 widens parameter j by s_j, F → S⁻¹ F S⁻¹ (the profiles of belief.profile),
    before the prior's precision is added."""
    F = 0.5 * (information + information.T)
    if stretch is not None:
        inverse = 1.0 / np.maximum(np.asarray(stretch, dtype=float), 1.0)
        F = F * np.outer(inverse, inverse)
    values, vectors = np.linalg.eigh(F)
    order = np.argsort(values)[::-1]
    values, vectors = np.clip(values[order], 0.0, None), vectors[:, order]
    vectors = vectors * np.sign(vectors[np.argmax(np.abs(vectors), axis=0), np.arange(vectors.shape[1])])
    prior = prior_precision(vectors)
    d = int(min(dim, np.sum(values > prior)))
    post = 1.0 / (values + prior)
    basis = vectors[:, :d] * np.sqrt(post[:d])
    complement = (vectors[:, d:] * post[d:]) @ vectors[:, d:].T
    return Directions(values, vectors, d, basis, complement)


def pinned_directions(jacobian: np.ndarray, noise_var: float, *, dim: int,
                      prior_rows: np.ndarray | None = None) -> Directions:
    """:func:`directions_of` the Gauss-Newton information :func:`fisher_information`."""
    return directions_of(fisher_information(jacobian, noise_var, prior_rows), dim=dim)


def best_local_fit(objective: Objective, result: IdentificationResult, config: LocalConfig
                   ) -> tuple[LocalFinish | None, list[dict[str, Any]]]:
    """Step 1: the lowest end point of the local fits from the ``config.starts`` best successful
    evaluations of ``result`` (None when no fit could run), and each fit's record."""
    hist = result.history
    ok = np.flatnonzero(hist["status"].values == "ok")
    order = ok[np.argsort(hist["error"].values[ok], kind="stable")]
    theta = np.asarray(hist["theta"].values, dtype=float)
    best: LocalFinish | None = None
    records = []
    for k in order[:config.starts]:
        fit, info = local_finish(objective, theta[k], config.fit)
        records.append({"start_error": float(hist["error"].values[k]), **info})
        if fit is not None and (best is None or fit.step.error < best.step.error):
            best = fit
    return best, records


def _times_prior(p: np.ndarray, log_prior: np.ndarray) -> np.ndarray:
    """p · exp(log prior), renormalized (cells of P = 0 stay 0)."""
    out = np.where(p > 0, np.log(np.maximum(p, 1e-300)) + log_prior, -np.inf)
    out = np.exp(out - out.max())
    return out / out.sum()


def towards_prior(centre: np.ndarray, directions: Directions) -> np.ndarray:
    """The complement's posterior mean (unit box): along each direction the grid does not span, the
    centre û moves towards the box's middle m = ½ by the prior's share of the precision,
    û + Σ_{k > grid} v_k π_k/(λ_k + π_k) v_kᵀ(m − û). The Gaussian that stands in for the uniform prior
    has the box's mean as well as its spread: a direction the data do not see keeps the box, not a
    box-wide normal centred wherever the fit happened to stop."""
    V = directions.vectors[:, directions.grid:]
    prior = prior_precision(V)
    share = prior / (directions.values[directions.grid:] + prior)
    return np.clip(centre + V @ (share * (V.T @ (0.5 - centre))), 0.0, 1.0)


def _data_jacobian(information: np.ndarray, noise_var: float, prior_rows: np.ndarray | None,
                   stretch: np.ndarray | None) -> np.ndarray:
    """A Jacobian J' (D x D, unit box) whose J'ᵀJ'/σ² is the data's part of the information P uses:
    S⁻¹ F S⁻¹ (F as E measured it, S the profiles' stretch) less the measurements' GᵀG, so that
    what the data pin (belief.identifiability) is what P shows, not what the fit's Jacobian alone says."""
    F = information if stretch is None else information / np.outer(np.maximum(stretch, 1.0), np.maximum(stretch, 1.0))
    if prior_rows is not None:
        F = F - prior_rows.T @ prior_rows
    values, vectors = np.linalg.eigh(0.5 * (F + F.T))
    return np.sqrt(np.clip(values, 0.0, None) * noise_var)[:, None] * vectors.T


def _journal(journal: str | os.PathLike[str] | None) -> str | None:
    return None if journal is None else os.path.splitext(os.fspath(journal))[0] + "-local.sqlite"


def _centre(fit: LocalFinish, noise_var: float, prior: MeasurementPrior | None, lower: np.ndarray) -> np.ndarray:
    """The local grid's centre in the unit box: the minimum of the quadratic approximation at the fit
    û, one regularized Newton step û − A⁻¹ (Jᵀr/σ² + Gᵀ r_m), A = JᵀJ/σ² + GᵀG + 12 I (r, J the
    residuals and Jacobian at û, r_m, G the standardized measurements and theirs; 12 I damps the
    step along directions the data barely see, as the box's spread would). A fit stops when a step
    gains under a nat, but along a weakly pinned ridge that can leave it many of its own sds from
    the minimum; the Laplace approximation belongs at the minimum, and a measured mass moves θ along
    the directions the data leave free."""
    unit = np.clip((fit.step.theta - lower) / fit.step.width, 0.0, 1.0)
    J = np.nan_to_num(fit.step.jacobian)
    r = np.nan_to_num(np.concatenate([np.ravel(x) for x in fit.residuals]))
    A = J.T @ J / noise_var + PRIOR_PRECISION * np.eye(unit.size)
    gradient = J.T @ r / noise_var
    if prior is not None and prior.measurements:
        G, r_m = prior.jacobian(fit.step.theta), prior.residuals(fit.step.theta)[0]
        A, gradient = A + G.T @ G, gradient + G.T @ r_m
    return np.clip(unit - np.linalg.solve(A, gradient), 0.0, 1.0)


def local_stage(objective: Objective, result: IdentificationResult, *, seed: int, config: LocalConfig = DEFAULT_LOCAL,
                level: float = 0.9, verdict_config: VerdictConfig | None = None, prior: MeasurementPrior | None = None,
                journal: str | os.PathLike[str] | None = None, progress: bool = True) -> IdentificationResult:
    """The module docstring's steps after the global search ``result``. ``prior``: what the user
    measured (its θ rows are the objective's). The returned result keeps the global search's history;
    its belief is the local one and ``config["local_stage"]`` records the stage. Raises
    :class:`NoLocalStage` with the reason when the global belief must stand (no residuals, a fit
    that diverged, nothing pinned)."""
    fit, starts = best_local_fit(objective, result, config)
    if fit is None:
        raise NoLocalStage("; ".join(dict.fromkeys(str(s.get("skipped", "")) for s in starts)) or "no fit ran")
    errors = np.asarray(result.history["error"].values, dtype=float)
    scale = calibrated_scale(fit.residuals, fit.step.jacobian, noise_floor=objective.noise_floor, config=config.scale,
                             least=1e-12 * float(np.nanmedian(errors)))
    rows = prior.jacobian(fit.step.theta) if prior is not None and prior.measurements else None
    space = objective.space
    centre = _centre(fit, scale.noise_var, prior, space.lower)
    curvature = secant_information(objective, centre, fisher_information(fit.step.jacobian, scale.noise_var, rows),
                                   scale.noise_var, reach=config.probe_sds, prior=prior)
    directions = directions_of(curvature.information, dim=config.dim)
    profiles = None
    if config.profile is not None and directions.grid > 0:
        profiles = profile_widths(objective, centre, fit.step.jacobian, directions.covariance(), scale.noise_var,
                                  level=level, prior=prior, config=config.profile)
        directions = directions_of(curvature.information, dim=config.dim, stretch=profiles.stretch)
    if directions.grid == 0:
        raise NoLocalStage("the data pin no direction beyond the box's own spread")
    decoder = LocalSubspace(space, towards_prior(centre, directions), directions.basis, span=config.span)
    grid = Grid.for_decoder(decoder, points_per_dim=config.points_per_dim)
    middle = int(np.argmin(np.sum(np.asarray(grid.points) ** 2, axis=1)))       # z = 0, evaluated first
    local = search(objective, decoder, grid, budget=min(config.budget, grid.size), seed=seed, journal=_journal(journal),
                   posterior=None, progress=progress,
                   proposer=BOProposer(seed, initial=WarmStart([middle], SobolDesign(seed))))
    belief = _belief(objective, decoder, grid, local, fit, scale, directions, level=level,
                     vcfg=verdict_config or VerdictConfig(), seed=seed, starts=starts, prior=prior)
    stretch = None if profiles is None else profiles.stretch
    belief.attrs["identifiability"] = identifiability(
        _data_jacobian(curvature.information, scale.noise_var, rows, stretch), noise_var=scale.noise_var,
        space=space, theta=fit.step.theta, width=fit.step.width, prior_rows=rows).as_dict()
    best_theta, best_error = result.best_theta, result.best_error
    candidates = [(fit.step.error, fit.step.theta), (local.best_error, np.asarray(local.best_theta.values))]
    error, theta = min(candidates, key=lambda c: c[0])
    if error < best_error:
        best_theta, best_error = best_theta.copy(data=np.asarray(theta, dtype=float)), float(error)
    config_out = dict(result.config)
    config_out["local_stage"] = {"evaluations": int(local.n_evaluations), "fit_evaluations": int(sum(
        s.get("evaluations", 0) for s in starts)), "directions": directions.grid, "best_error": float(best_error),
        "probe_evaluations": curvature.evaluations, "curvature": [float(v) for v in curvature.ratio],
        "profile": None if profiles is None else profiles.as_dict()}
    return IdentificationResult(belief=belief, history=result.history, best_theta=best_theta, best_error=best_error,
                                config=config_out)


def _belief(objective: Objective, decoder: LocalSubspace, grid: Grid, local: IdentificationResult, fit: LocalFinish,
            scale: Scale, directions: Directions, *, level: float, vcfg: VerdictConfig, seed: int,
            starts: list[dict[str, Any]], prior: MeasurementPrior | None) -> Belief:
    """Steps 4-6: P over the local grid (times the user's measurements), the complement's spread,
    marginals and verdicts."""
    records = local.records()
    model = fit_surrogate(records, grid, SurrogateConfig())
    if model is None:
        raise BeliefError("the local grid's search has fewer than 2 successful evaluations; the posterior needs 2.")
    pcfg = PosteriorConfig(noise_var=scale.noise_var, level=level)
    failed = np.zeros(grid.size, dtype=bool)
    failed[[r.cell for r in records if r.status != "ok"]] = True
    pred = model.predict(grid.points)
    P = posterior_from_surrogate(model, grid, config=pcfg, noise_var=scale.noise_var, failed=failed, seed=seed,
                                 prediction=pred, noise_known=True)
    space = objective.space
    widths = space.upper - space.lower
    spread = ComplementSpread(tuple(map(tuple, directions.complement * np.outer(widths, widths))))
    theta_cells = decoder.decode(np.asarray(grid.points))
    evaluated = [(fit.step.error, fit.step.theta)] + [(r.error, np.asarray(r.theta)) for r in records
                                                      if r.status == "ok"]
    scores = [e / (2 * scale.noise_var) for e, _ in evaluated]
    if prior is not None and prior.measurements:
        P = P.copy(data=_times_prior(P.values, prior.log_density(theta_cells).reshape(P.shape)))
        scores = [sc - float(prior.log_density(t)[0]) for sc, (_, t) in zip(scores, evaluated, strict=True)]
    marg = marginals(P, theta_cells, space, level=level, identified_ratio=vcfg.identified_ratio, spread=spread)
    vmass = verified_mass(P.values.ravel(), loglik_sd(*pred, shift=model.shift_, noise_var=scale.noise_var),
                          max_sd=vcfg.max_loglik_sd)
    best = evaluated[int(np.argmin(scores))][1]
    bound = pinned(marg, at_bounds(space, fit.step.theta, tolerance=vcfg.bound_tolerance, source="local fit"),
                   weak_ratio=vcfg.weak_ratio)
    verdicts, reasons = decide(marg, best_theta=best, verified=vmass, config=vcfg,
                               conflicts={a.name: because("at bound", a.reason()) for a in bound})
    attrs = {"mode": "likelihood", "level": level, "noise_var": scale.noise_var, "noise_rule": "calibrated",
             "noise": scale.as_dict(), "verified_mass": vmass, "n_evaluations": int(local.n_evaluations),
             "n_successful": int(sum(r.status == "ok" for r in records)), "best_error": float(min(fit.step.error,
                                                                                                  local.best_error)),
             "budget_warning": "", "local_fit": {**fit.info, "starts": starts},
             "at_bounds": [a.as_dict() for a in bound], "bound_tolerance": vcfg.bound_tolerance,
             "error_floor": None, "best_cell_mass": float(P.values.max()), "trust": "",
             "directions": {"values": directions.values.tolist(), "grid": directions.grid}}
    return Belief(P, theta_cells, space, decoder_config=decoder.config(), grid_config=grid.config(),
                  verdicts=verdicts, reasons=reasons, attrs=attrs, level=level, grid=grid, spread=spread)
