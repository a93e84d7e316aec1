"""Verdicts per parameter: identified, weakly identified or not identified, each with the rule that
decided it and its reason.

A narrow marginal is necessary but not sufficient. Under model error, or with a budget too small
for the dimension, P can be narrow in the wrong place (the GP's lower tail on cells nobody
evaluated, or a minimum of E that model error moved away from the truth). The verdict of
parameter j therefore combines the checks below, each a named rule (:data:`RULES`); every reason
starts with the name of the rule that decided it, then says why in plain words ("narrowing: the
data narrow it to 17% of its prior spread ..."). The rule names are for code (:func:`rule_of`,
``Belief.rules``); a user reads :func:`plain_reason`, the words alone.

- **reach** (checked first): reach_j = prior_std_j / (width_j / √12), the spread of θ_j over the
  decoded cells relative to a uniform spread over its box. A decoder that varies θ_j over only a
  sliver of the box (reach < ``min_reach``: a trained decoder's narrow image, a direction the
  embedding dropped) never tried the other values, so a narrow P there says nothing about the
  truth -> not identified.
- **narrowing**: ratio_j = std_j / prior_std_j of the marginal of P.
  ratio >= ``weak_ratio`` -> not identified; ``identified_ratio`` <= ratio < ``weak_ratio`` ->
  weakly identified.
- **local width** (when the objective gives residuals): r and its Jacobian J at the best
  evaluated θ̂ give the local posterior std over all D parameters, sqrt diag (JᵀJ/σ²)⁻¹ in the
  unit box, divided by the box's uniform std 1/√12. When larger than P's ratio it replaces it in
  every rule that reads the narrowing: a decoder that holds fixed a direction trading off with θ_j
  (μ in S = J²/(2 m² μ), with m searched) makes P narrow in θ_j; the full-space ratio is not.
- **segment consistency** (time windows, trajectories): each segment s has its own posterior P_s
  (same evaluations, its own part of E). If two segments both narrow θ_j (ratio <
  ``identified_ratio``) and their ``level`` credible intervals are disjoint, the best value of θ_j
  moves with the data by more than its interval: model error, not information -> not identified.
  (Two independent 90 % intervals of a correct model are disjoint with probability ~2 %.)
- **verified mass**: the GP knows the log-likelihood ℓ = −E/(2σ²) of a cell to within
  sd_ℓ ≈ |dℓ/dt| s (delta method on the GP's t = log(E − shift) or t = E, predictive sd s). The
  verified mass is Σ P over cells with sd_ℓ <= ``max_loglik_sd`` nats. Below
  ``min_verified_mass``, P rests on the GP's guesses -> at most weakly identified.
- **evaluated support**: the best evaluated θ_j must lie inside the credible interval of θ_j,
  otherwise P contradicts the evaluations -> not identified, whatever the narrowing (a weakly
  identified interval that excludes the best evaluation is as wrong as an identified one). The
  likelihood's evaluated floor (:mod:`belief.posterior`) keeps every cell at or below the best
  evaluation's weight, so this fires only when P spreads over many cells nobody evaluated on one
  side of the best (the best cell then holds less than (1 − level)/2 of P: a cell holding more
  lies inside every marginal interval).
- **local refit** (when the objective gives residuals, and some parameter would otherwise be
  identified or weakly identified): one damped Gauss-Newton step from θ̂ to θ′
  (:func:`belief.least_squares.gauss_newton_step`, D + 4 evaluations; the same step gives the
  local width). If it lowers E by more than ``refit_nats`` nats, (E(θ̂) − E(θ′)) / (2σ²) >
  refit_nats, or by more than the fraction ``refit_fraction`` of E(θ̂) (minimizer mode: by more
  than 1 % of E(θ̂)), the data prefer a θ′ that P never weighed: the search stopped short of the
  best fit (a decoder whose image misses it, a budget too small for the dimension). A parameter
  whose θ′_j lies outside its interval -> not identified. The fraction is needed because σ²
  estimated from the residuals at θ̂ counts as noise the very misfit the step removes: then
  E(θ̂)/(2σ²) is about n_eff/2, and with few effective observations (noiseless data, a search
  short of the truth) no gain can reach ``refit_nats``.
- **at bound** (model inadequacy, :mod:`belief.bounds`): the fitted θ (θ′ of the local refit when
  the step moved, else θ̂) within ``bound_tolerance`` x width of a bound of the box, in a
  parameter the data narrow (narrowing or local width below ``weak_ratio``) -> not identified:
  the fit would leave the box, so the value is the bound, not an estimate. A parameter the data do
  not narrow can sit on the edge by chance (in 15-D about a quarter of uniform points have some
  coordinate within 1 % of a bound; a clipping decoder such as REMBO puts many cells there) and is
  not identified by the narrowing already. The pinned parameters are listed in the Belief
  (``Belief.at_bounds``) and its summary.

Only a parameter that passes all of them is *identified*. The order of precedence when several
fire (:func:`decide`): reach; segment consistency, local refit and at bound (the ``conflicts``);
narrowing; evaluated support; narrowing again for "weakly"; verified mass. The budget rule of
thumb for a GP in d dimensions, n >= 10 d evaluations (Loeppky, Sacks & Welch 2009), is reported
as a warning with the numbers when it is not met.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr

from belief.bounds import AT_BOUND_TOLERANCE, AtBound
from belief.errors import BeliefError
from belief.reasons import RULES, because, narrowed, plain_reason, rule_of, share_of

__all__ = ["VERDICTS", "RULES", "because", "rule_of", "plain_reason", "VerdictConfig", "reach_reason",
           "default_verdicts", "loglik_sd", "verified_mass", "segment_conflicts", "refit_conflicts", "pinned",
           "unsupported", "trust_note", "decide", "budget_warning"]

VERDICTS = ("identified", "weakly identified", "not identified")

@dataclass(frozen=True)
class VerdictConfig:
    """Thresholds of the verdict rules (module docstring), validated."""

    identified_ratio: float = 0.5
    weak_ratio: float = 0.8
    max_loglik_sd: float = 1.0
    min_verified_mass: float = 0.5
    evaluations_per_dim: int = 10
    min_reach: float = 0.5
    refit: bool = True
    refit_nats: float = 3.0
    refit_fraction: float = 0.5
    bound_tolerance: float = AT_BOUND_TOLERANCE

    def __post_init__(self) -> None:
        if not (isinstance(self.bound_tolerance, (int, float)) and 0 <= self.bound_tolerance < 0.5):
            raise BeliefError(f"VerdictConfig.bound_tolerance must be a fraction of the box width in [0, 0.5) "
                              f"(the 'at bound' rule), got {self.bound_tolerance!r}.")
        if not (np.isfinite(self.refit_nats) and self.refit_nats > 0):
            raise BeliefError(f"VerdictConfig.refit_nats must be a positive number of nats, got {self.refit_nats!r}.")
        if not (np.isfinite(self.refit_fraction) and 0 < self.refit_fraction < 1):
            raise BeliefError(f"VerdictConfig.refit_fraction must lie in (0, 1) (the share of E a local step must "
                              f"remove), got {self.refit_fraction!r}.")
        if not (np.isfinite(self.min_reach) and 0 <= self.min_reach <= 1):
            raise BeliefError(f"VerdictConfig.min_reach must lie in [0, 1], got {self.min_reach!r}.")
        if not (0 < self.identified_ratio <= self.weak_ratio <= 1):
            raise BeliefError(f"VerdictConfig needs 0 < identified_ratio <= weak_ratio <= 1, got "
                              f"{self.identified_ratio!r} and {self.weak_ratio!r}.")
        if not (np.isfinite(self.max_loglik_sd) and self.max_loglik_sd > 0):
            raise BeliefError("VerdictConfig.max_loglik_sd must be a positive number of nats, got "
                              f"{self.max_loglik_sd!r}.")
        if not (0 <= self.min_verified_mass <= 1):
            raise BeliefError(f"VerdictConfig.min_verified_mass must lie in [0, 1], got {self.min_verified_mass!r}.")
        if not isinstance(self.evaluations_per_dim, int) or self.evaluations_per_dim < 0:
            raise BeliefError("VerdictConfig.evaluations_per_dim must be an int >= 0, got "
                              f"{self.evaluations_per_dim!r}.")


def reach_reason(reach: float) -> str:
    """Why a parameter the decoder barely varies is not identified (the "reach" rule)."""
    return because("reach", f"the search varied it over only {reach:.0%} of its box's spread: values elsewhere "
                            "were never tried, so the data cannot say whether the truth lies there")


def default_verdicts(marg: xr.Dataset) -> tuple[list[str], list[str]]:
    """Verdicts from P alone, with ratio_j = std_j / prior_std_j of the marginals ``marg``.

    ratio < 0.5 -> identified, ratio < 0.8 -> weakly identified, else not identified (the default
    :class:`~belief.verdicts.VerdictConfig` thresholds, without its evidence checks). A parameter
    the decoder does not vary over the cells (prior_std = 0), or over less than ``min_reach`` of its
    box (the "reach" rule of :mod:`belief.verdicts`), is not identified.
    """
    cfg = VerdictConfig()
    verdicts, reasons = [], []
    reach = marg["reach"].values if "reach" in marg else np.ones(marg.sizes["parameter"])
    for std, prior, spread in zip(marg["std"].values, marg["prior_std"].values, reach, strict=True):
        if not prior > 0:
            verdicts.append(VERDICTS[2])
            reasons.append(because("reach", "the search never varied it, so the data say nothing about it"))
            continue
        if spread < cfg.min_reach:
            verdicts.append(VERDICTS[2])
            reasons.append(reach_reason(float(spread)))
            continue
        r = float(std / prior)
        verdicts.append(VERDICTS[0] if r < cfg.identified_ratio else VERDICTS[1] if r < cfg.weak_ratio else VERDICTS[2])
        reasons.append(because("narrowing", (
            f"{narrowed(r)} (from the posterior alone: identified below {cfg.identified_ratio:.0%}, weakly "
            f"identified below {cfg.weak_ratio:.0%})")))
    return verdicts, reasons


def loglik_sd(mean: np.ndarray, var: np.ndarray, *, shift: float | None, noise_var: float) -> np.ndarray:
    """sd of ℓ = −E/(2σ²) per cell from the GP's predictive (mean, var) of t (shape ``n``).

    t = log(E − shift): dℓ/dt = −exp(t)/(2σ²), so sd_ℓ ≈ exp(m) s/(2σ²); t = E (``shift`` None):
    sd_ℓ = s/(2σ²). Computed in logs so large exponents give inf, not overflow warnings.
    """
    s = np.sqrt(np.maximum(np.asarray(var, dtype=float), 0.0))
    log2s2 = np.log(2.0 * noise_var)
    with np.errstate(divide="ignore", over="ignore"):
        if shift is None:
            return np.exp(np.log(s) - log2s2)
        return np.exp(np.minimum(np.asarray(mean, dtype=float) + np.log(s) - log2s2, 700.0))


def verified_mass(p: np.ndarray, sd: np.ndarray, *, max_sd: float) -> float:
    """Σ P over cells whose log-likelihood sd is at most ``max_sd`` nats (``p``, ``sd``: shape ``n``)."""
    return float(np.sum(np.asarray(p, dtype=float)[np.asarray(sd) <= max_sd]))


def _interval(marginals: xr.Dataset, name: str) -> str:
    """The credible interval of parameter ``name`` as "[lower, upper]"."""
    m = marginals.sel(parameter=name)
    return f"[{float(m['lower']):.4g}, {float(m['upper']):.4g}]"


def segment_conflicts(segment_marginals: Mapping[str, xr.Dataset], *, identified_ratio: float) -> dict[str, str]:
    """Parameters whose credible intervals from two segments are disjoint while both are narrow.

    ``segment_marginals``: segment name -> marginals Dataset (``mean``, ``std``, ``lower``,
    ``upper``, ``prior_std`` over ``parameter``). Returns parameter -> reason (only conflicting ones).
    """
    out: dict[str, str] = {}
    names = list(segment_marginals)
    for a_i, a in enumerate(names):
        ma = segment_marginals[a]
        for b in names[a_i + 1:]:
            mb = segment_marginals[b]
            narrow = (ma["std"] < identified_ratio * ma["prior_std"]) & (mb["std"] < identified_ratio * mb["prior_std"])
            apart = (ma["upper"] < mb["lower"]) | (mb["upper"] < ma["lower"])
            for name in ma["parameter"].values[(narrow & apart).values]:
                key = str(name)
                if key not in out:
                    out[key] = because("segment consistency", f"parts of the data disagree on it: part {a} "
                                       f"gives {_interval(ma, key)}, part {b} gives {_interval(mb, key)}, so the "
                                       "model does not fit them alike")
    return out


def refit_conflicts(marginals: xr.Dataset, theta: np.ndarray | Sequence[float], error: float, start_error: float, *,
                    noise_var: float | None, nats: float,
                    fraction: float = VerdictConfig.refit_fraction) -> dict[str, str]:
    """Parameters whose interval excludes a significantly better local fit θ′ (the "local refit" rule).

    ``theta``: θ′ (D,); ``error``, ``start_error``: E(θ′) and E(θ̂); ``noise_var``: σ² of the
    likelihood (None in minimizer mode); significant: a gain above ``nats`` or above ``fraction``
    of E(θ̂). Returns parameter -> reason (only conflicting ones).
    """
    gain = float(start_error) - float(error)
    share = gain / max(float(start_error), 1e-300)
    if noise_var is not None:
        score = gain / (2.0 * noise_var)
        significant = score > nats or share > fraction
        how = f"{share:.0%} lower" + (", more than the noise explains" if score > nats else "")
    else:
        significant, how = share > 0.01, f"{share:.1%} lower"
    if not significant:
        return {}
    out: dict[str, str] = {}
    for j, name in enumerate(str(n) for n in marginals["parameter"].values):
        lo, hi, v = float(marginals["lower"].values[j]), float(marginals["upper"].values[j]), float(theta[j])
        tol = 1e-9 * max(abs(hi), abs(lo), 1e-300)
        if not (lo - tol <= v <= hi + tol):
            out[name] = because("local refit", (
                f"a local fit from the best evaluation lowers the error from {start_error:.4g} to {error:.4g} ({how}) "
                f"at {v:.4g}, outside the interval [{lo:.4g}, {hi:.4g}]: the search stopped before the best fit, "
                "so the interval sits in the wrong place"))
    return out


def pinned(marginals: xr.Dataset, found: Sequence[AtBound], *, weak_ratio: float,
           local_ratio: np.ndarray | Sequence[float] | None = None) -> tuple[AtBound, ...]:
    """The entries of ``found`` (belief.bounds.at_bounds of the fitted θ) whose parameter the data
    narrow (the "at bound" rule): ratio < ``weak_ratio``, the ratio being the larger of
    std / prior_std in ``marginals`` and ``local_ratio`` (D,) of the "local width" rule when given."""
    names = [str(n) for n in marginals["parameter"].values]
    local = np.zeros(len(names)) if local_ratio is None else np.asarray(local_ratio, dtype=float)
    narrow = {n for j, n in enumerate(names)
              if float(marginals["prior_std"].values[j]) > 0 and _ratio(marginals, j, float(local[j]))[0] < weak_ratio}
    return tuple(a for a in found if a.name in narrow)


def budget_warning(n_ok: int, dim: int, *, per_dim: int, failed: int = 0, reserved: int = 0) -> str:
    """A message when the GP fitted n_ok < per_dim x dim successful evaluations of a ``dim``-dimensional
    search, else "". It counts what the GP saw, the search's evaluations; the budget it suggests adds
    the ``failed`` ones (as many failures again) and the ``reserved`` evaluations the run spends after
    the search (the Gauss-Newton step after it, belief.assess.finishing_cost), so that a run with that
    budget gives the GP per_dim x dim."""
    need = per_dim * dim
    if n_ok >= need:
        return ""
    extra = (f", {failed} for as many failures" if failed else "") + \
        (f", {reserved} for the Gauss-Newton step after the search" if reserved else "")
    split = f" ({need} for the GP{extra})" if extra else ""
    return (f"{n_ok} successful evaluations for a {dim}-dimensional search: a GP needs about {per_dim} per "
            f"dimension ({need}) to map E, and it fits the search's evaluations only; P follows the GP's guesses "
            f"between them. Verdicts require verified mass and evaluated support; for sharper answers give a budget "
            f"of {need + failed + reserved} evaluations of E{split} or search a "
            f"lower-dimensional embedding.")


def unsupported(marginals: xr.Dataset, best_theta: np.ndarray | Sequence[float]) -> dict[str, str]:
    """Parameters whose credible interval excludes the best evaluated θ (the "evaluated support" rule).

    ``marginals``: Dataset with ``lower``, ``upper`` over ``parameter``; ``best_theta``: θ̂ (D,).
    Returns parameter -> reason (only the contradicted ones; a relative tolerance of 1e-9).
    """
    best = np.asarray(best_theta, dtype=float)
    out: dict[str, str] = {}
    for j, name in enumerate(str(n) for n in marginals["parameter"].values):
        lo, hi = float(marginals["lower"].values[j]), float(marginals["upper"].values[j])
        tol = 1e-9 * max(abs(hi), abs(lo), 1e-300)
        if not (lo - tol <= best[j] <= hi + tol):
            out[name] = because("evaluated support", (
                f"the posterior contradicts its evaluations: the best evaluated value {best[j]:.4g} lies outside the "
                f"interval [{lo:.4g}, {hi:.4g}], so the interval rests on values nobody evaluated"))
    return out


def _sharp_verdict(vmass: float, cfg: VerdictConfig, said: str, rule: str) -> tuple[str, str]:
    """The verdict of a parameter narrowed below ``identified_ratio`` (``said``: by how much, in words):
    the "verified mass" rule caps it."""
    if vmass < cfg.min_verified_mass:
        return "weakly identified", because("verified mass", (
            f"{said}, but only {vmass:.0%} of the posterior lies where the error is known from "
            "evaluations: the interval rests on guesses between them"))
    return "identified", because(rule, f"{said}; {vmass:.0%} of the posterior lies where the error is "
                                       "known from evaluations, and the best evaluation lies inside the interval")


def _ratio(marg: xr.Dataset, j: int, local: float, *, reduced: bool = False) -> tuple[float, str, str]:
    """(narrowing ratio, rule, note): the larger of P's std/prior_std ("narrowing") and the local
    ratio ("local width"), with a note when the local one is larger; it blames the decoder only when
    ``reduced`` (a decoder of fewer dimensions than the parameters made P: it held the rest fixed)."""
    ratio = float(marg["std"].values[j] / max(float(marg["prior_std"].values[j]), 1e-300))
    if local <= ratio:
        return ratio, "narrowing", ""
    alone = f"the posterior alone narrows it to {share_of(ratio, 'its prior spread')}, but " if ratio < 0.995 else ""
    held = "; the search's decoder held those fixed, which made the posterior narrow" if reduced else ""
    return local, "local width", (f" ({alone}a local fit over all parameters leaves it this wide: other parameters "
                                  f"can make up for a change in it{held})")


def trust_note(marginals: xr.Dataset, verdicts: Sequence[str], *, best_theta: np.ndarray | Sequence[float],
               verified: float, best_mass: float, config: VerdictConfig | None = None,
               local_ratio: np.ndarray | Sequence[float] | None = None) -> str:
    """Why P cannot be trusted, for the summary, or "" when it can (the "evaluated support" and
    "verified mass" rules).

    Said when some parameter the data narrow (ratio < ``weak_ratio``, "narrowing" or "local width")
    has an interval that excludes the best evaluated θ, or when P's ``verified`` mass is below
    ``min_verified_mass`` while some parameter is still (weakly) identified.
    ``verdicts``: one per parameter (from :func:`decide`); ``best_mass``: P of the best evaluated cell.
    """
    cfg = config or VerdictConfig()
    names = [str(n) for n in marginals["parameter"].values]
    local = np.zeros(len(names)) if local_ratio is None else np.asarray(local_ratio, dtype=float)
    narrow = [n for j, n in enumerate(names) if float(marginals["prior_std"].values[j]) > 0
              and _ratio(marginals, j, float(local[j]))[0] < cfg.weak_ratio]
    bad = [n for n in narrow if n in unsupported(marginals, best_theta)]
    kept = [n for n, v in zip(names, verdicts, strict=True) if v != VERDICTS[2]]
    where = (f"{verified:.0%} of P's mass lies on cells whose likelihood the GP knows to {cfg.max_loglik_sd:g} nat "
             f"and {best_mass:.1%} on the best evaluation")
    if bad:
        return (f"P contradicts its evaluations: the interval of {', '.join(bad)} excludes the best evaluated value "
                f"({where}); P rests on cells nobody evaluated, so these are not identified. Raise the budget.")
    if kept and verified < cfg.min_verified_mass:
        return (f"P rests partly on the GP's guesses: only {where}; the intervals of {', '.join(kept)} hold the "
                "best evaluation but are at most weakly identified.")
    return ""


def decide(marginals: xr.Dataset, *, best_theta: np.ndarray | Sequence[float], verified: float,
           conflicts: Mapping[str, str] | None = None, config: VerdictConfig | None = None,
           local_ratio: np.ndarray | Sequence[float] | None = None,
           reduced: bool = False) -> tuple[list[str], list[str]]:
    """(verdicts, reasons), one per parameter of ``marginals`` (module docstring; "segment consistency",
    "local refit" and "at bound" enter through ``conflicts``; "evaluated support",
    :func:`unsupported`, applies to every parameter the data narrow). Every reason names its rule.

    ``best_theta``: θ of the best evaluation (D,); ``verified``: P's verified mass in [0, 1];
    ``conflicts``: parameter -> reason (:func:`because`), from :func:`segment_conflicts`,
    :func:`refit_conflicts` or the "at bound" rule (:meth:`belief.bounds.AtBound.reason` of :func:`pinned`);
    ``local_ratio``: (D,) local posterior std over the box's uniform std ("local width"), or None;
    ``reduced``: P's cells come from a decoder of fewer dimensions than the parameters (a latent grid).
    """
    cfg = config or VerdictConfig()
    best = np.asarray(best_theta, dtype=float)
    names = [str(n) for n in marginals["parameter"].values]
    if best.shape != (len(names),):
        raise BeliefError(f"best_theta must have shape ({len(names)},), got {best.shape}.")
    conflicts = conflicts or {}
    contradicted = unsupported(marginals, best)
    local = np.zeros(len(names)) if local_ratio is None else np.asarray(local_ratio, dtype=float)
    verdicts, reasons = [], []
    reach = marginals["reach"].values if "reach" in marginals else np.ones(len(names))
    for j, name in enumerate(names):
        ratio, rule, note = _ratio(marginals, j, float(local[j]), reduced=reduced)
        said = narrowed(ratio, "its box's spread" if rule == "local width" else "its prior spread")
        if reach[j] < cfg.min_reach:
            v, why = "not identified", reach_reason(float(reach[j]))
        elif name in conflicts:
            v, why = "not identified", conflicts[name]
        elif ratio >= cfg.weak_ratio:
            v, why = "not identified", because(rule, said + ("" if ratio >= 0.995 else ", too little"))
        elif name in contradicted:
            v, why = "not identified", f"{contradicted[name]} ({said})"
        elif ratio >= cfg.identified_ratio:
            v, why = "weakly identified", because(rule, f"{said}, not enough to rely on")
        else:
            v, why = _sharp_verdict(verified, cfg, said, rule)
        verdicts.append(v)
        reasons.append(why + note)
    return verdicts, reasons
