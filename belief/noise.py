"""The noise level σ² of the likelihood posterior, from the structure of the residuals.

The likelihood posterior weighs a cell by exp(−E/(2σ²)), with E a sum of K squared residuals.
Two rules give σ² (``PosteriorConfig.noise_rule``):

``"iid"``: every residual is an independent Gaussian sample, so the residual variance at the
best fit is the noise variance::

    σ²_iid = E_min / max(K − d, 1)                      (d = latent dimension)

``"ess"`` (default): under model error the residuals are not independent noise. They are
smooth in time and shared across the 36 coordinates of a sample (rigid rods), so K residuals
carry far fewer than K independent numbers, and the iid rule makes the likelihood K/K_eff times
too sharp. The rule counts the *effective* number of residuals from the residuals r (T_s x m) of
each segment s at the best evaluated θ::

    m_eff,s = (tr S)² / tr(S²),  S = Σ_i r_i r_iᵀ         participation ratio of the m coordinates
    ρ_s(k)  = mean_i(r_i · r_{i+k}) / mean_i(r_i · r_i)    autocorrelation in time (not centred)
    τ_s     = 1 + 2 Σ_{k=1}^{W} ρ_s(k)                      integrated autocorrelation time, with
              Sokal's window: the smallest W >= c τ_s(W), c = 5; τ_s clipped to [1, T_s]
    K_eff   = Σ_s m_eff,s T_s / τ_s
    σ²_ess  = σ²_iid · K / K_eff

Model error also *moves* the minimum of E: the best fit can beat the truth by a few per cent of
E in every segment (with noisy states the one-step error prefers parameters that damp the
propagated noise; with another engine's data, parameters that mimic its missing effects). The
rule therefore also bounds the likelihood's sharpness by a relative discrepancy δ, the excess
error, as a fraction of E_min, that costs one nat::

    σ² = max(σ²_iid · K / K_eff,  δ E_min / 2),   δ = max(δ_0, δ_seg)
    δ_seg = median_s (E_s(θ̂) − min_k E_s(θ_k)) / E_s(θ̂)

δ_seg is the evidence of the data: how much worse the overall best θ̂ fits segment s than that
segment's own best evaluated θ_k (zero when all segments agree). δ_0 (``PosteriorConfig.discrepancy``,
default :data:`DEFAULT_DISCREPANCY` = 0.2) is the floor for what segments cannot show: a bias shared
by all of them. Its size is a prior on model error: on data from the identifier's own model the truth
fits a few per cent worse than the best evaluation, on another engine's robot 13-70 % worse, with
the segments agreeing (δ_seg ≈ 0); measured data always carry such error (docs/identification.md).

The autocorrelation is not centred on purpose: a constant bias in the residuals (a sensor offset,
a wrong ground height) is one number, however many samples repeat it, and keeps ρ near 1.
White noise gives τ ≈ 1 and m_eff ≈ m, so σ²_ess ≈ σ²_iid: the rule only tempers the
likelihood where the residuals show structure. It is a generalized-Bayes temperature
K_eff/K on the iid likelihood, selected by the residuals' autocorrelation (the batch-means
effective sample size of MCMC output analysis, Sokal 1997; Geyer 1992).

An objective that knows its noise (``objective.noise_var``, e.g. the push toy with declared noise)
keeps that value; the rules apply when it is unknown.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from belief.errors import BeliefError

__all__ = ["DEFAULT_DISCREPANCY", "NOISE_RULES", "EffectiveSize", "effective_size", "iid_noise_var",
           "noise_var_from_residuals", "segment_discrepancy"]

#: the selectable rules for σ² when the objective does not know its noise ("calibrated": belief.scale,
#: from the residuals and Jacobian at the local fit; the two below from the residuals alone)
NOISE_RULES = ("calibrated", "ess", "iid")

#: δ_0, the relative excess error over E_min that costs one nat at least (module docstring)
DEFAULT_DISCREPANCY = 0.2

_SOKAL_C = 5.0


@dataclass(frozen=True)
class EffectiveSize:
    """Effective residual count of each segment: ``samples`` T_s (rows compared), ``tau`` τ_s
    (integrated autocorrelation time, samples), ``coords`` m_eff,s (participation ratio), and
    their totals ``n`` = Σ T_s m and ``n_eff`` = K_eff = Σ m_eff,s T_s / τ_s."""

    samples: tuple[int, ...]
    tau: tuple[float, ...]
    coords: tuple[float, ...]
    n: int
    n_eff: float

    def as_dict(self) -> dict[str, object]:
        return {"samples": list(self.samples), "tau": list(self.tau), "coords": list(self.coords),
                "n": self.n, "n_eff": self.n_eff}


def _autocorrelation_time(r: np.ndarray) -> float:
    """τ of the rows of ``r`` (T x m, NaN rows allowed: pairs with a NaN row are skipped)."""
    T = r.shape[0]
    ok = np.isfinite(r).all(axis=1)
    x = np.where(ok[:, None], r, 0.0)
    c0 = float(np.einsum("ij,ij->", x, x)) / max(int(ok.sum()), 1)
    if c0 <= 0.0 or T < 2:
        return 1.0
    tau = 1.0
    for k in range(1, T):
        pairs = int((ok[:-k] & ok[k:]).sum())
        if pairs == 0:
            continue
        rho = float(np.einsum("ij,ij->", x[:-k], x[k:])) / pairs / c0
        tau += 2.0 * rho
        if k >= _SOKAL_C * tau:
            break
    return float(np.clip(tau, 1.0, T))


def _participation_ratio(r: np.ndarray) -> float:
    """(tr S)² / tr(S²) of S = Σ_i r_i r_iᵀ over the finite rows of ``r`` (T x m); in [1, m]."""
    x = r[np.isfinite(r).all(axis=1)]
    S = x.T @ x
    tr2 = float(np.einsum("ij,ij->", S, S))
    if tr2 <= 0.0:
        return 1.0
    return float(np.clip(np.trace(S) ** 2 / tr2, 1.0, r.shape[1]))


def effective_size(residuals: Sequence[np.ndarray]) -> EffectiveSize:
    """K_eff of residual segments (list of T_s x m arrays, time along rows); module docstring."""
    if len(residuals) == 0:
        raise BeliefError("effective_size needs at least one residual segment (a list of T x m arrays), got none.")
    samples, taus, coords = [], [], []
    n = 0
    for k, r in enumerate(residuals):
        arr = np.asarray(r, dtype=float)
        if arr.ndim == 1:
            arr = arr[:, None]
        if arr.ndim != 2:
            raise BeliefError(f"residual segment {k} must be a T x m array, got shape {arr.shape}.")
        rows = int(np.isfinite(arr).all(axis=1).sum())
        if rows == 0:
            continue
        samples.append(rows)
        taus.append(_autocorrelation_time(arr))
        coords.append(_participation_ratio(arr))
        n += rows * arr.shape[1]
    if n == 0:
        raise BeliefError("effective_size: every residual row is NaN; nothing was compared.")
    n_eff = float(sum(c * t / tau for c, t, tau in zip(coords, samples, taus, strict=True)))
    return EffectiveSize(tuple(samples), tuple(taus), tuple(coords), n, min(n_eff, float(n)))


def iid_noise_var(errors: np.ndarray, *, n_observations: int, dim: int) -> float:
    """σ²_iid = E_min / max(K − d, 1), floored at 1e-12 x median(E) (E: the observed errors)."""
    e = np.asarray(errors, dtype=float)
    e = e[np.isfinite(e)]
    if e.size == 0:
        raise BeliefError("cannot estimate the noise variance: no successful evaluation.")
    if np.any(e < 0):
        raise BeliefError(
            "the likelihood posterior needs non-negative errors (a sum of squared residuals); got "
            f"min E = {e.min()!r}. Use posterior='minimizer' or make the objective non-negative."
        )
    sigma2 = float(e.min()) / max(int(n_observations) - int(dim), 1)
    return max(sigma2, 1e-12 * max(float(np.median(e)), 1e-300))


def segment_discrepancy(parts: np.ndarray) -> float:
    """δ_seg = median_s (E_s(θ̂) − min_k E_s(θ_k)) / E_s(θ̂) over the n x S segment errors of the
    successful evaluations (θ̂ = the row with the smallest total); 0 with a single segment."""
    p = np.asarray(parts, dtype=float)
    if p.ndim != 2 or p.shape[0] < 1:
        raise BeliefError(f"parts must be an n x S array of segment errors, got shape {p.shape}.")
    if p.shape[1] < 2:
        return 0.0
    best = p[int(np.argmin(p.sum(axis=1)))]
    rel = (best - p.min(axis=0)) / np.maximum(best, 1e-300)
    return float(np.median(rel))


def noise_var_from_residuals(errors: np.ndarray, residuals: Sequence[np.ndarray], *, dim: int,
                             discrepancy: float = 0.0) -> tuple[float, EffectiveSize]:
    """σ² = max(σ²_iid · K / K_eff, δ E_min / 2) with K, K_eff from the residual segments at the best θ.

    ``errors``: observed E of the successful evaluations (n,); ``residuals``: the best θ's residual
    segments (T_s x m each); ``discrepancy``: δ. Returns (σ², the EffectiveSize behind it).
    """
    if not (np.isfinite(discrepancy) and discrepancy >= 0):
        raise BeliefError(f"discrepancy must be a finite fraction >= 0 of E_min, got {discrepancy!r}.")
    size = effective_size(residuals)
    base = iid_noise_var(errors, n_observations=size.n, dim=dim)
    e_min = float(np.nanmin(np.asarray(errors, dtype=float)))
    return max(base * size.n / max(size.n_eff, 1.0), 0.5 * discrepancy * e_min), size
