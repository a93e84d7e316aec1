"""Log expected improvement over the grid cells, and batches of q cells (kriging believer).

For minimization with GP posterior f(z) ~ N(mu, s^2) and incumbent ``best`` (smallest observed t)::

    u = (best - mu) / s,     EI = s h(u),     h(u) = phi(u) + u Phi(u)

``log h`` is evaluated as in Ament et al. 2023 ("Unexpected improvements to expected improvement
for Bayesian optimization", NeurIPS, eq. 9), which stays finite and accurate where EI underflows:

- u > -1:               log h = log(phi(u) + u Phi(u))
- -1/sqrt(eps) < u <= -1: log h = -u^2/2 - log(2 pi)/2 + log1mexp(log(erfcx(-u/sqrt 2) |u|) + log(pi/2)/2)
- u <= -1/sqrt(eps):    log h = -u^2/2 - log(2 pi)/2 - 2 log|u|

Batch (q > 1, Zhu et al. 2018 evaluate in parallel): *kriging believer* (Ginsbourger et al. 2010):
pick the best cell, pretend its outcome equals the GP mean there (pseudo-observation, same
hyperparameters, see ``GPSurrogate.fantasize``), recompute log EI, repeat q times. The believer
shrinks the variance around chosen cells, spreading the batch. Ties resolve to the lowest cell
index, so the choice is a deterministic function of the data.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.special import erfcx, ndtr

from belief.errors import BeliefError

if TYPE_CHECKING:                   # the GP (torch, pyro) loads only where it is fitted
    from belief.surrogate import GPSurrogate

__all__ = ["log_h", "log_expected_improvement", "select_cells"]

_C1 = 0.5 * np.log(2.0 * np.pi)
_C2 = 0.5 * np.log(np.pi / 2.0)
_INV_SQRT_EPS = 1.0 / np.sqrt(np.finfo(float).eps)


def _log1mexp(x: np.ndarray) -> np.ndarray:
    """log(1 - exp(x)) for x < 0 (Maechler 2012)."""
    return np.where(x > -np.log(2.0), np.log(-np.expm1(x)), np.log1p(-np.exp(x)))


def log_h(u: np.ndarray) -> np.ndarray:
    """log(phi(u) + u Phi(u)), elementwise, stable for all finite u (see module docstring)."""
    u = np.asarray(u, dtype=float)
    out = np.empty_like(u)
    a = u > -1.0
    ua = u[a]
    phi = np.exp(-0.5 * ua**2 - _C1)
    out[a] = np.log(phi + ua * ndtr(ua))
    b = (~a) & (u > -_INV_SQRT_EPS)
    ub = u[b]
    out[b] = -0.5 * ub**2 - _C1 + _log1mexp(np.log(erfcx(-ub / np.sqrt(2.0)) * np.abs(ub)) + _C2)
    c = ~(a | b)
    uc = u[c]
    out[c] = -0.5 * uc**2 - _C1 - 2.0 * np.log(np.abs(uc))
    return out


def log_expected_improvement(mean: np.ndarray, var: np.ndarray, best: float) -> np.ndarray:
    """log EI(z) = log s + log h((best - mu) / s) for minimization; ``mean``, ``var`` shape ``n`` -> ``n``.

    Cells with zero variance get log EI = log(max(best - mu, 0)) (``-inf`` when no improvement).
    """
    mu = np.asarray(mean, dtype=float)
    v = np.asarray(var, dtype=float)
    if mu.shape != v.shape:
        raise BeliefError(f"mean and var must have the same shape, got {mu.shape} and {v.shape}.")
    s = np.sqrt(np.maximum(v, 0.0))
    out = np.empty_like(mu)
    pos = s > 1e-12 * max(1.0, abs(best))
    out[pos] = np.log(s[pos]) + log_h((best - mu[pos]) / s[pos])
    with np.errstate(divide="ignore"):
        out[~pos] = np.log(np.maximum(best - mu[~pos], 0.0))
    return out


def select_cells(
    surrogate: GPSurrogate,
    points: np.ndarray,
    available: np.ndarray,
    *,
    q: int = 1,
    prediction: tuple[np.ndarray, np.ndarray] | None = None,
) -> list[int]:
    """Indices of q cells maximizing log EI among ``available`` ones (kriging believer for q > 1).

    ``surrogate``: a fitted :class:`~belief.surrogate.GPSurrogate`; ``points``: cell centres
    ``n x d``; ``available``: boolean mask ``n`` (False = already evaluated); ``prediction``:
    optional precomputed (mean, var) of shape ``n`` for the first pick.
    """
    avail = np.array(available, dtype=bool, copy=True)
    if avail.shape != (points.shape[0],):
        raise BeliefError(f"available must be a boolean mask of shape ({points.shape[0]},), got {avail.shape}.")
    if q < 1:
        raise BeliefError(f"q must be >= 1, got {q!r}.")
    if avail.sum() < q:
        raise BeliefError(f"only {int(avail.sum())} unevaluated cells left, cannot pick q={q}; use a finer grid.")
    chosen: list[int] = []
    model = surrogate
    best = float(surrogate.best_t_)
    mean, var = prediction if prediction is not None else model.predict(points)
    for k in range(q):
        lei = log_expected_improvement(mean, var, best)
        lei[~avail] = -np.inf
        if not np.any(np.isfinite(lei)):
            # no cell promises improvement: fall back to the largest posterior variance (pure exploration)
            score = np.where(avail, var, -np.inf)
        else:
            score = lei
        j = int(np.argmax(score))
        chosen.append(j)
        avail[j] = False
        if k + 1 < q:
            model = model.fantasize(points[j:j + 1], mean[j:j + 1])
            mean, var = model.predict(points)
    return chosen
