"""The posterior P over the grid cells, its credible region and its marginals in θ units.

Two modes (Zhu et al. 2018 return "a distribution P on discretized Θ"; the paper leaves its form
open, we offer two documented ones). The prior is uniform over the cells.

``likelihood`` (as in BOLFI, Gutmann & Corander 2016): with E a sum of squared residuals and
Gaussian observation noise of variance sigma^2, the likelihood is exp(-E / (2 sigma^2)); P is the
GP expectation of it::

    P(z) ∝ E_f[ exp(-E(z) / (2 sigma^2)) ]

- without log transform, f = E ~ N(m, s^2) is rectified at 0 (E >= 0), in closed form
  (a = 1 / (2 sigma^2))::

      E[exp(-a max(f, 0))] = Phi(-m/s) + exp(-a m + a^2 s^2 / 2) Phi((m - a s^2) / s)

  which tends to exp(-m/(2 sigma^2) + s^2/(8 sigma^4)) (the unrectified Gaussian formula) when
  m >> s, and stays <= 1 where the GP is uncertain;
- with the log transform, f = log(E - shift) ~ N(m, s^2), the expectation is split at the floor
  (exact below it) and taken by Gauss-Legendre quadrature (32 nodes) above it
  (:func:`_log_transform_expectation`).

**Evaluated floor** (``PosteriorConfig.floor``): E is floored at the smallest evaluated error
E_min, E -> max(E, E_min), so that no cell outweighs the best evaluation::

    P(z) ∝ E_f[ exp(-max(E(z), E_min) / (2 sigma^2)) ] <= exp(-E_min / (2 sigma^2))

"auto" (default) floors when sigma^2 is estimated from the evaluations (the noise rules below),
not when it is known (given, or the objective's ``noise_var``); "best" always, "zero" never (E >= 0
only, the unfloored posterior). An estimated sigma^2 takes the best evaluation's misfit as what
noise and model error leave (the "iid" and "ess" rules from its residuals, δ E_min / 2 from
E_min): a cell predicted to fit better than E_min contradicts the very premise of that sigma^2,
and the GP's claim that a cell nobody evaluated beats every evaluation (its mean dipping below
E_min, or its lower tail) is what expected improvement bets on, not evidence. In 15-D with tens of
evaluations its lengthscales cannot resolve a valley a few per cent of the box wide, and
exp(-E/(2 sigma^2)) turns an extrapolated improvement of a fraction of E_min into many nats (the
log transform lets the tail reach E_min - c, c = the median excess error). Without the floor, P
then piles on such cells and its interval can exclude the best evaluated θ (testbed flops,
docs/identification.md). With it, a cell predicted at or below E_min ties with the best
evaluation, weighted by the GP's probability that it does. A known sigma^2 sets the scale of E
independently of the search: when BO has not yet reached the noise level, cells the GP predicts
below E_min are where the data are explained (the push toy's ridge: flooring there lowered the
coverage of the 90 % region from 68 to 59 of 100 problems at 30 evaluations).

sigma^2 is given, or the objective's ``noise_var`` when it knows it, else set by a noise rule of
:mod:`belief.noise` (``PosteriorConfig.noise_rule``): "ess" (default) tempers the independent-noise
estimate by the effective number of residuals, which the residuals' autocorrelation in time and
across coordinates gives; "iid" is E_min / max(K - d, 1). Cells whose simulation failed get P = 0
(no parameter that breaks the simulator explains the data).

``minimizer``: P(z) = Pr[z = argmin E] under the GP. Exact joint samples (Cholesky of the joint
posterior covariance) on the ``max_subset`` cells with the smallest lower confidence bound
m - 3 s (the others have a negligible chance to be the minimizer), ``n_samples`` draws with
``numpy.random.default_rng(seed)``; P(z) = fraction of draws whose argmin is z.

P is an ``xarray.DataArray`` named "P" over the grid dims, non-negative, summing to 1.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
import xarray as xr
from scipy.special import log_ndtr, logsumexp

from belief.errors import BeliefError
from belief.noise import DEFAULT_DISCREPANCY, NOISE_RULES, iid_noise_var
from belief.spread import CellSpread, ComplementSpread, complement_marginals, spread_marginals

if TYPE_CHECKING:
    from belief.grid import CandidateSet
    from belief.surrogate import GPSurrogate
    from physics.parameters import ParameterSpace

__all__ = [
    "FLOORS",
    "PosteriorConfig",
    "error_floor",
    "estimate_noise_var",
    "log_likelihood",
    "posterior_from_surrogate",
    "credible_mask",
    "credible_region",
    "marginals",
    "entropy",
]

_GL_X, _GL_W = np.polynomial.legendre.leggauss(32)
_CHUNK = 4096

#: where the likelihood floors E: at the best evaluated error when σ² is estimated, always, or at 0 only
FLOORS = ("auto", "best", "zero")


@dataclass(frozen=True)
class PosteriorConfig:
    """Options of the posterior (validated).

    ``mode``: "likelihood" or "minimizer"; ``noise_var``: sigma^2 in units of E (None = from the
    objective or estimated by ``noise_rule``, "ess" or "iid", :mod:`belief.noise`); ``floor``: where
    the likelihood floors E, "auto" (at the smallest evaluated error when sigma^2 is estimated, at 0
    when it is known), "best" or "zero" (module docstring); ``discrepancy``:
    δ_0 of the "ess" rule, the relative excess error that costs one nat at least (a prior on
    model error, :data:`belief.noise.DEFAULT_DISCREPANCY`; 0.05 suits data from this very model);
    ``n_samples``/``max_subset``: minimizer-mode sampling;
    ``level``: credible level of the marginal interval; ``identified_ratio``: a parameter is
    *identified* when its posterior std < identified_ratio x its prior std.
    """

    mode: Literal["likelihood", "minimizer"] = "likelihood"
    noise_var: float | None = None
    noise_rule: str = "ess"
    floor: str = "auto"
    discrepancy: float = DEFAULT_DISCREPANCY
    n_samples: int = 2000
    max_subset: int = 1000
    level: float = 0.9
    identified_ratio: float = 0.5

    def __post_init__(self) -> None:
        if self.mode not in ("likelihood", "minimizer"):
            raise BeliefError(f"posterior mode must be 'likelihood' or 'minimizer', got {self.mode!r}.")
        if self.noise_rule not in NOISE_RULES:
            raise BeliefError(f"noise_rule must be one of {NOISE_RULES}, got {self.noise_rule!r}.")
        if self.floor not in FLOORS:
            raise BeliefError(f"floor must be one of {FLOORS} (E floored at the best evaluated error when σ² is "
                              f"estimated, always, or at 0 only), got {self.floor!r}.")
        if not (np.isfinite(self.discrepancy) and self.discrepancy >= 0):
            raise BeliefError(f"discrepancy must be a fraction >= 0 of E_min (e.g. 0.2), got {self.discrepancy!r}.")
        if self.noise_var is not None and not (np.isfinite(self.noise_var) and self.noise_var > 0):
            raise BeliefError(f"noise_var must be a positive number (units of E) or None, got {self.noise_var!r}.")
        if not isinstance(self.n_samples, int) or self.n_samples < 1:
            raise BeliefError(f"n_samples must be an int >= 1, got {self.n_samples!r}.")
        if not isinstance(self.max_subset, int) or self.max_subset < 2:
            raise BeliefError(f"max_subset must be an int >= 2, got {self.max_subset!r}.")
        if not (0 < self.level < 1):
            raise BeliefError(f"level must lie in (0, 1), e.g. 0.9, got {self.level!r}.")
        if not (0 < self.identified_ratio <= 1):
            raise BeliefError(f"identified_ratio must lie in (0, 1], got {self.identified_ratio!r}.")


def estimate_noise_var(errors: np.ndarray, *, n_observations: int = 1, dim: int = 0) -> float:
    """sigma^2 = E_min / max(K - d, 1), the "iid" rule (:func:`belief.noise.iid_noise_var`)."""
    return iid_noise_var(errors, n_observations=n_observations, dim=dim)


def log_likelihood(mean: np.ndarray, var: np.ndarray, *, noise_var: float, shift: float | None,
                   floor: float = 0.0) -> np.ndarray:
    """log E_f[exp(-max(E, F) / (2 sigma^2))] per cell, from the GP of t (``shift`` None: t = E; else
    t = log(E - shift)); F = max(``floor``, 0) (module docstring: the evaluated floor).

    ``mean``, ``var``: shape ``n`` in t units -> shape ``n``. With a = 1 / (2 sigma^2) and
    f ~ N(m, s^2), t = E has the closed form::

        E[exp(-a max(f, F))] = Phi((F - m)/s) exp(-a F) + exp(-a m + a^2 s^2 / 2) Phi((m - F - a s^2)/s)

    and the log transform (E = exp(f) + shift) is :func:`_log_transform_expectation`.
    """
    m = np.asarray(mean, dtype=float)
    s = np.sqrt(np.maximum(np.asarray(var, dtype=float), 1e-300))
    a = 1.0 / (2.0 * noise_var)
    F = max(float(floor), 0.0)
    if shift is None:
        term = -a * m + 0.5 * a**2 * s**2 + log_ndtr((m - F - a * s**2) / s)
        return np.logaddexp(log_ndtr((F - m) / s) - a * F, term)
    out = np.empty_like(m)
    for st in range(0, m.size, _CHUNK):
        out[st:st + _CHUNK] = _log_transform_expectation(m[st:st + _CHUNK], s[st:st + _CHUNK], a, float(shift), F)
    return out


def _log_transform_expectation(m: np.ndarray, s: np.ndarray, a: float, shift: float, F: float) -> np.ndarray:
    """log E[exp(-a max(exp(f) + shift, F))], f ~ N(m, s^2) (``m``, ``s``: shape ``n``), split at the
    floor's f* = log(F - shift) (f* = -inf when F <= shift)::

        = Phi(z*) exp(-a F)  +  exp(-a (e^L + shift)) ∫_L^U exp(-b (e^(f - L) - 1)) N(f; m, s^2) df

    z* = (f* - m)/s, b = a e^L; below f* the floor holds exactly (first term). Above it,
    L = max(f*, m - 8s) and U = min(m + 8s, L + log1p(40 / b)): beyond U the Gaussian (8 sd) or the
    likelihood (40 nats under its value at L) is negligible. The integral is Gauss-Legendre
    (``_GL_X``, 32 nodes) in the standardized z = (f - m)/s over [z_L, z_U] ⊂ [-8, 8], which
    resolves both factors: a whole Gaussian over [-8, 8] is off by 3e-12, and the result agrees
    with adaptive quadrature to ~1e-13 nat (tests/belief/test_evaluated_support.py). Gauss-Hermite
    over f, which this replaces, was off by up to 0.6 nat when the likelihood changes by tens of
    nats within one sd, which the floor makes common near the best evaluation. A vanishing s is
    exact (the interval shrinks to the point m); b is capped at e^700 (such a cell's likelihood is
    0 to double precision) and the result at the most negative float, so it is never NaN or -inf.
    Work arrays: nodes x n.
    """
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        fstar = np.log(F - shift) if F > shift else -np.inf
        z_star = (fstar - m) / s
        first = log_ndtr(z_star) - a * F if F > shift else np.full(m.shape, -np.inf)
        z_lo = np.maximum(z_star, -8.0)
        log_b = np.minimum(np.log(a) + m + s * z_lo, 700.0)             # log(a e^L), capped
        z_hi = np.minimum(8.0, z_lo + np.log1p(np.exp(np.log(40.0) - log_b)) / s)
        half = np.maximum(z_hi - z_lo, 0.0) / 2.0
        z = _GL_X[:, None] * half + (z_lo + half)                        # nodes x n
        terms = np.expm1(np.minimum((z - z_lo) * s, 700.0))
        terms *= -np.exp(log_b)                                          # -b (e^(f - L) - 1)
        terms -= 0.5 * z * z
        top = terms.max(axis=0)
        second = top + np.log(_GL_W @ np.exp(terms - top))
        second += np.log(half) - 0.5 * np.log(2 * np.pi) - np.exp(log_b) - a * shift
        second = np.where(half > 0, second, -np.inf)
        return np.maximum(np.logaddexp(first, second), -np.finfo(float).max)


def error_floor(surrogate: GPSurrogate, config: PosteriorConfig, *, noise_known: bool = False) -> float:
    """F of the likelihood (module docstring): the smallest error the surrogate was fitted to with
    ``config.floor`` "best", or "auto" and σ² estimated (``noise_known`` False); else 0."""
    if config.floor == "zero" or (config.floor == "auto" and noise_known):
        return 0.0
    return max(float(np.min(surrogate.errors_)), 0.0)


def _normalize_log(logp: np.ndarray, failed: np.ndarray | None) -> np.ndarray:
    lp = np.array(logp, dtype=float, copy=True)
    if failed is not None:
        lp[failed] = -np.inf
    if not np.any(np.isfinite(lp)):
        raise BeliefError("posterior is zero everywhere (every cell failed or has zero likelihood).")
    lp -= logsumexp(lp)
    p = np.exp(lp)
    return p / p.sum()


def posterior_from_surrogate(
    surrogate: GPSurrogate,
    grid: CandidateSet,
    *,
    config: PosteriorConfig,
    noise_var: float | None = None,
    failed: np.ndarray | None = None,
    seed: int = 0,
    prediction: tuple[np.ndarray, np.ndarray] | None = None,
    noise_known: bool = False,
) -> xr.DataArray:
    """P over ``grid`` from a fitted surrogate (module docstring); returns the DataArray "P".

    ``failed``: boolean mask of cells (shape ``n``) whose evaluation failed (P = 0 there); in the
    likelihood mode E is floored at ``error_floor(surrogate, config, noise_known=noise_known)``
    (attrs["error_floor"]; ``noise_known``: σ² was given or known by the objective, not estimated);
    ``noise_var``: sigma^2 for the likelihood mode (required there); ``prediction``: optional
    precomputed (mean, var) of t on ``grid.points``.
    """
    pts = grid.points
    if config.mode == "likelihood":
        if noise_var is None:
            raise BeliefError("likelihood posterior needs noise_var (sigma^2); pass it or use estimate_noise_var.")
        if surrogate.shift_ is None and np.any(surrogate.errors_ < 0):
            raise BeliefError(
                "likelihood posterior needs non-negative errors; use posterior='minimizer' or shift the objective."
            )
        mean, var = prediction if prediction is not None else surrogate.predict(pts)
        floor = error_floor(surrogate, config, noise_known=noise_known)
        p = _normalize_log(log_likelihood(mean, var, noise_var=noise_var, shift=surrogate.shift_, floor=floor),
                           failed)
    else:
        p = _minimizer_probability(surrogate, pts, config=config, failed=failed, seed=seed, prediction=prediction)
    da = grid.to_dataarray(p, name="P")
    da.attrs.update({"mode": config.mode, "long_name": "posterior probability of each cell"})
    if noise_var is not None and config.mode == "likelihood":
        da.attrs["noise_var"] = float(noise_var)
        da.attrs["error_floor"] = error_floor(surrogate, config, noise_known=noise_known)
    return da


def _minimizer_probability(surrogate: GPSurrogate, pts: np.ndarray, *, config: PosteriorConfig,
                           failed: np.ndarray | None, seed: int,
                           prediction: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    mean, var = prediction if prediction is not None else surrogate.predict(pts)
    lcb = mean - 3.0 * np.sqrt(var)
    if failed is not None:
        lcb = np.where(failed, np.inf, lcb)
    k = int(min(config.max_subset, np.isfinite(lcb).sum()))
    if k < 1:
        raise BeliefError("minimizer posterior: no cell left (every cell failed).")
    idx = np.argsort(lcb, kind="stable")[:k]
    m, cov = surrogate.predict_joint(pts[idx])
    cov = 0.5 * (cov + cov.T)
    jitter = 1e-10 * max(float(np.mean(np.diag(cov))), 1e-300)
    for _ in range(12):
        try:
            L = np.linalg.cholesky(cov + jitter * np.eye(k))
            break
        except np.linalg.LinAlgError:
            jitter *= 10.0
    else:  # pragma: no cover - only with a broken covariance
        raise BeliefError("minimizer posterior: joint covariance is not positive definite even with jitter.")
    rng = np.random.default_rng(seed)
    counts = np.zeros(k)
    for st in range(0, config.n_samples, 500):
        ns = min(500, config.n_samples - st)
        f = m[:, None] + L @ rng.standard_normal((k, ns))
        counts += np.bincount(np.argmin(f, axis=0), minlength=k)
    p = np.zeros(pts.shape[0])
    p[idx] = counts / counts.sum()
    return p


def credible_mask(p: np.ndarray, *, level: float = 0.9) -> np.ndarray:
    """Highest-posterior-density set: the fewest cells whose mass reaches ``level`` (flat bool mask ``n``).

    Cells are taken in decreasing P (ties by index); the cell that crosses ``level`` is included.
    """
    flat = np.asarray(p, dtype=float).ravel()
    if not (0 < level < 1):
        raise BeliefError(f"level must lie in (0, 1), got {level!r}.")
    order = np.argsort(-flat, kind="stable")
    csum = np.cumsum(flat[order])
    n_in = int(np.searchsorted(csum, level * csum[-1], side="left")) + 1
    mask = np.zeros(flat.size, dtype=bool)
    mask[order[:n_in]] = True
    return mask


def credible_region(P: xr.DataArray, *, level: float = 0.9) -> xr.DataArray:
    """The ``level`` highest-posterior-density region of P as a boolean DataArray of P's shape."""
    mask = credible_mask(P.values, level=level).reshape(P.shape)
    return P.copy(data=mask).rename("credible_region")


def entropy(P: xr.DataArray) -> float:
    """Shannon entropy -sum P log P [nats] (0 log 0 = 0)."""
    p = np.asarray(P.values, dtype=float).ravel()
    p = p[p > 0]
    return float(-(p * np.log(p)).sum())


def _cell_quantiles(p: np.ndarray, th: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray]:
    """The (1-level)/2 and (1+level)/2 quantiles (D,) each of P (n,) over the cell values th (n, D)."""
    lo_q, hi_q = 0.5 * (1 - level), 0.5 * (1 + level)
    lower, upper = np.empty(th.shape[1]), np.empty(th.shape[1])
    for j in range(th.shape[1]):
        order = np.argsort(th[:, j], kind="stable")
        cdf = np.cumsum(p[order])
        cdf /= cdf[-1]
        lower[j] = th[order[min(int(np.searchsorted(cdf, lo_q, side="left")), p.size - 1)], j]
        upper[j] = th[order[min(int(np.searchsorted(cdf, hi_q, side="left")), p.size - 1)], j]
    return lower, upper


def marginals(
    P: xr.DataArray,
    theta: np.ndarray,
    space: ParameterSpace,
    *,
    level: float = 0.9,
    identified_ratio: float = 0.5,
    spread: CellSpread | ComplementSpread | None = None,
) -> xr.Dataset:
    """Per-parameter summaries of P pushed through the decoder, in θ units.

    ``theta``: decoded cell centres ``n x D`` (same cell order as ``P.values.ravel()``). With
    weights p (P) and prior weights 1/n (uniform over cells), per parameter j:

    - ``mean`` = sum p θ_j, ``std`` = sqrt(sum p (θ_j - mean)^2);
    - ``lower``/``upper``: the (1-level)/2 and (1+level)/2 quantiles of the weighted distribution;
    - ``map``: θ of the most probable cell; ``prior_mean``/``prior_std``: same under the prior;
    - ``reach`` = prior_std / ((upper_j - lower_j) / sqrt(12)): how much of the box the decoder spans;
    - ``identified`` = std < identified_ratio x prior_std (a uniform prior's std is width/sqrt(12),
      so with ratio 0.5 the posterior must be at least twice as narrow as the prior);
    - with ``spread`` (belief.spread), the spread cell's mass is its local truncated normal, not a
      point: mean, std and the interval are the mixture's (map and prior moments unchanged);
    - with a :class:`~belief.spread.ComplementSpread` (a local belief, belief.local_belief), every
      cell is spread by the complement's normal, and the prior is the box, uniform: prior_mean its
      centre, prior_std its width / sqrt(12), reach 1.

    Returns an ``xarray.Dataset`` over dimension ``parameter`` (coordinate ``unit``).
    """
    p = np.asarray(P.values, dtype=float).ravel()
    th = np.asarray(theta, dtype=float)
    if th.ndim != 2 or th.shape[0] != p.size or th.shape[1] != space.dim:
        raise BeliefError(f"theta must have shape ({p.size}, {space.dim}), got {th.shape}.")
    prior_mean = th.mean(axis=0)
    prior_std = th.std(axis=0)
    if isinstance(spread, ComplementSpread):
        prior_mean, prior_std = 0.5 * (space.lower + space.upper), (space.upper - space.lower) / np.sqrt(12.0)
        mean, std, lower, upper = complement_marginals(p / p.sum(), th, spread, space.lower, space.upper, level)
    elif spread is not None:
        mean, std, lower, upper = spread_marginals(p / p.sum(), th, spread, space.lower, space.upper, level)
    else:
        mean = p @ th
        std = np.sqrt(np.maximum(p @ (th - mean) ** 2, 0.0))
        lower, upper = _cell_quantiles(p, th, level)
    identified = std < identified_ratio * np.maximum(prior_std, 1e-300)
    coords = {"parameter": list(space.names), "unit": ("parameter", list(space.units))}
    dims = ("parameter",)
    ds = xr.Dataset(
        {
            "mean": (dims, mean), "std": (dims, std), "lower": (dims, lower), "upper": (dims, upper),
            "map": (dims, th[int(np.argmax(p))]), "prior_mean": (dims, prior_mean),
            "prior_std": (dims, prior_std), "identified": (dims, identified),
            "reach": (dims, prior_std / np.maximum((space.upper - space.lower) / np.sqrt(12.0), 1e-300)),
        },
        coords=coords,
    )
    ds.attrs.update({"level": float(level), "identified_ratio": float(identified_ratio)})
    return ds
