"""The local spread of the best evaluated cell: P's mass there is not a point.

P lives on cells, and a cell's decoded θ_c is a point. When one cell holds most of P (a warm
start far better than anything the search found, low-noise data, a coarse grid in many
dimensions), every quantile of a marginal is θ_cj and the credible interval has zero width: the
width of the grid's resolution, not of the data. At the best evaluated cell the "local width"
rule (belief.verdicts) measures the data's own width, the Laplace std of the Gauss-Newton step,
s_j = sqrt diag (JᵀJ/σ²)⁻¹ (belief.least_squares). The marginal of θ_j is then the mixture

    F_j(x) = Σ_{k≠c} p_k 1[θ_kj <= x] + p_c T_j(x),

T_j the normal N(μ_j, s_j²) truncated to the box [lower_j, upper_j], μ = θ_c, or the local fit's
end point θ̂ when the fit ran from that cell (``centre``): the cell stands for the basin it lies
in, whose minimum and curvature the fit measured. The credible interval is its (1 − level)/2 and
(1 + level)/2 quantiles; mean and std are its moments. Only the best cell gets a spread: it is the
one whose curvature was measured, and the one whose mass makes the intervals collapse. With the
local covariance (``cov``, D x D, the Laplace approximation σ² (JᵀJ)⁻¹ in θ units), draws of that
cell's mass (``Belief.sample``) come from N(μ, cov) truncated to the box (rejection, then the
nearest point of the box for the few a thin box rejects 1000 times); without it, they stay on the
cell's centre.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import ndtr

from belief.errors import BeliefError

__all__ = ["CellSpread", "ComplementSpread", "spread_marginals", "spread_draws", "complement_marginals",
           "complement_draws"]


@dataclass(frozen=True)
class CellSpread:
    """The local std ``std`` (D,) in θ units of cell ``cell`` (an index into P's cells); ``inf``
    for a direction the data do not see (uniform over the box), 0 for a point."""

    cell: int
    std: tuple[float, ...]
    centre: tuple[float, ...] | None = None
    cov: tuple[tuple[float, ...], ...] | None = None

    def __post_init__(self) -> None:
        s = np.asarray(self.std, dtype=float)
        if self.centre is not None:
            c = np.asarray(self.centre, dtype=float)
            if c.shape != s.shape or not np.all(np.isfinite(c)):
                raise BeliefError(f"CellSpread.centre must be a finite θ with {s.size} values, got {self.centre!r}.")
            object.__setattr__(self, "centre", tuple(float(v) for v in c))
        if self.cov is not None:
            m = np.asarray(self.cov, dtype=float)
            if m.shape != (s.size, s.size) or not np.all(np.isfinite(m)):
                raise BeliefError(f"CellSpread.cov must be a finite {s.size} x {s.size} matrix, got shape {m.shape}.")
            object.__setattr__(self, "cov", tuple(tuple(float(v) for v in row) for row in m))
        if isinstance(self.cell, bool) or not isinstance(self.cell, (int, np.integer)) or self.cell < 0:
            raise BeliefError(f"CellSpread.cell must be a cell index >= 0, got {self.cell!r}.")
        if s.ndim != 1 or np.any(np.isnan(s)) or np.any(s < 0):
            raise BeliefError(f"CellSpread.std must be a vector of stds >= 0 (inf allowed), got {self.std!r}.")
        object.__setattr__(self, "cell", int(self.cell))
        object.__setattr__(self, "std", tuple(float(v) for v in s))

    def as_dict(self) -> dict[str, Any]:
        """JSON-able form (inf as the string "inf")."""
        record: dict[str, Any] = {"cell": self.cell, "std": [v if np.isfinite(v) else "inf" for v in self.std]}
        if self.centre is not None:
            record["centre"] = list(self.centre)
        if self.cov is not None:
            record["cov"] = [list(row) for row in self.cov]
        return record

    @classmethod
    def from_dict(cls, record: Mapping[str, Any]) -> CellSpread:
        """Inverse of :meth:`as_dict`."""
        try:
            centre = record.get("centre")
            cov = record.get("cov")
            return cls(int(record["cell"]), tuple(float(v) for v in record["std"]),
                       None if centre is None else tuple(float(v) for v in centre),
                       None if cov is None else tuple(tuple(float(v) for v in row) for row in cov))
        except (KeyError, TypeError, ValueError) as exc:
            raise BeliefError(f"corrupt cell spread record {record!r} ({exc}); re-save the belief.") from None


def _truncated(mu: float, s: float, lo: float, hi: float) -> tuple[float, float]:
    """(mean, variance) of N(mu, s²) truncated to [lo, hi]; a point at mu for s = 0, uniform for a
    width s far beyond the box."""
    if s <= 0 or hi <= lo:
        return mu, 0.0
    if s > 1e6 * (hi - lo):
        return 0.5 * (lo + hi), (hi - lo) ** 2 / 12.0
    a, b = (lo - mu) / s, (hi - mu) / s
    z = float(ndtr(b) - ndtr(a))
    if z < 1e-12:
        return float(np.clip(mu, lo, hi)), 0.0
    pa, pb = np.exp(-0.5 * a * a) / np.sqrt(2 * np.pi), np.exp(-0.5 * b * b) / np.sqrt(2 * np.pi)
    shift = (pa - pb) / z
    var = 1.0 + (a * pa - b * pb) / z - shift ** 2
    return mu + s * shift, max(var, 0.0) * s * s


def _truncated_cdf(x: float, mu: float, s: float, lo: float, hi: float) -> float:
    """CDF at x of N(mu, s²) truncated to [lo, hi] (a step at mu for s = 0; uniform for huge s)."""
    if s <= 0 or hi <= lo:
        return 1.0 if x >= mu else 0.0
    if s > 1e6 * (hi - lo):
        return float(np.clip((x - lo) / (hi - lo), 0.0, 1.0))
    a, b = ndtr((lo - mu) / s), ndtr((hi - mu) / s)
    if b - a < 1e-12:
        return 1.0 if x >= np.clip(mu, lo, hi) else 0.0
    return float(np.clip((ndtr((min(max(x, lo), hi) - mu) / s) - a) / (b - a), 0.0, 1.0))


def _quantile(values: np.ndarray, cdf: np.ndarray, atom: tuple[float, float, float, float, float], q: float) -> float:
    """inf {x : F(x) >= q} of F(x) = cdf[searchsorted(values, x, right) - 1] + w T(x), by bisection;
    ``values`` sorted, ``cdf`` their cumulative weights, ``atom`` = (w, mu, s, lo, hi)."""
    w, mu, s, lo_box, hi_box = atom

    def F(x: float) -> float:
        k = int(np.searchsorted(values, x, side="right"))
        return (cdf[k - 1] if k > 0 else 0.0) + w * _truncated_cdf(x, mu, s, lo_box, hi_box)

    lo = min(lo_box, float(values[0]) if values.size else lo_box, mu)
    hi = max(hi_box, float(values[-1]) if values.size else hi_box, mu)
    if F(lo) >= q:
        return lo
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        lo, hi = (lo, mid) if F(mid) >= q else (mid, hi)
    return hi


def spread_marginals(p: np.ndarray, theta: np.ndarray, spread: CellSpread, lower: np.ndarray, upper: np.ndarray,
                     level: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(mean, std, lower quantile, upper quantile), each (D,), of the mixture of the module docstring.

    ``p`` (n,): P, summing to 1; ``theta`` (n, D): decoded cells; ``lower``/``upper`` (D,): the box.
    """
    n, dim = theta.shape
    if not (0 <= spread.cell < n) or len(spread.std) != dim:
        raise BeliefError(f"the cell spread is for cell {spread.cell} with {len(spread.std)} stds; the belief has "
                          f"{n} cells and {dim} parameters.")
    c, w = spread.cell, float(p[spread.cell])
    rest = np.ones(n, dtype=bool)
    rest[c] = False
    out = np.empty((4, dim))
    for j in range(dim):
        lo, hi = float(lower[j]), float(upper[j])
        mu = float(np.clip(theta[c, j] if spread.centre is None else spread.centre[j], lo, hi))
        s = spread.std[j]
        m_t, v_t = _truncated(mu, s, lo, hi)
        mean = float(p[rest] @ theta[rest, j]) + w * m_t
        var = float(p[rest] @ (theta[rest, j] - mean) ** 2) + w * (v_t + (m_t - mean) ** 2)
        order = np.argsort(theta[rest, j], kind="stable")
        values, cdf = theta[rest, j][order], np.cumsum(p[rest][order])
        atom = (w, mu, s, lo, hi)
        out[:, j] = (mean, np.sqrt(max(var, 0.0)), _quantile(values, cdf, atom, 0.5 * (1 - level)),
                     _quantile(values, cdf, atom, 0.5 * (1 + level)))
    return out[0], out[1], out[2], out[3]


def spread_draws(spread: CellSpread, centre: np.ndarray, lower: np.ndarray, upper: np.ndarray, n: int,
                 rng: np.random.Generator) -> np.ndarray:
    """n draws (n x D) of the spread cell's mass: N(μ, cov) truncated to the box by rejection (module
    docstring), μ = ``spread.centre`` or the cell's ``centre``; n copies of μ without a covariance."""
    mu = np.asarray(spread.centre if spread.centre is not None else centre, dtype=float)
    mu = np.clip(mu, lower, upper)
    if spread.cov is None or n == 0:
        return np.repeat(mu[None], n, axis=0)
    cov = np.asarray(spread.cov, dtype=float)
    values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
    root = vectors * np.sqrt(np.clip(values, 0.0, None))
    out = np.empty((n, mu.size))
    todo = np.arange(n)
    for _ in range(1000):
        if todo.size == 0:
            break
        draws = mu + rng.standard_normal((todo.size, mu.size)) @ root.T
        inside = np.all((draws >= lower) & (draws <= upper), axis=1)
        out[todo[inside]] = draws[inside]
        todo = todo[~inside]
    if todo.size:
        out[todo] = np.clip(mu + rng.standard_normal((todo.size, mu.size)) @ root.T, lower, upper)
    return out


@dataclass(frozen=True)
class ComplementSpread:
    """The spread every cell of a local belief carries: the posterior of the directions its decoder
    holds at the fit (belief.local_belief), a normal with covariance ``cov`` (D x D, θ units), added
    to each cell's θ and truncated to the box. The prior of such a belief is the box, not its cells."""

    cov: tuple[tuple[float, ...], ...]

    def __post_init__(self) -> None:
        m = np.asarray(self.cov, dtype=float)
        if m.ndim != 2 or m.shape[0] != m.shape[1] or not np.all(np.isfinite(m)) or np.any(np.diag(m) < 0):
            raise BeliefError(f"ComplementSpread.cov must be a finite square covariance, got shape {m.shape}.")
        object.__setattr__(self, "cov", tuple(tuple(float(v) for v in row) for row in m))

    @property
    def std(self) -> np.ndarray:
        """sqrt diag cov (D,)."""
        return np.sqrt(np.diag(np.asarray(self.cov, dtype=float)))

    def as_dict(self) -> dict[str, Any]:
        return {"kind": "complement", "cov": [list(row) for row in self.cov]}

    @classmethod
    def from_dict(cls, record: Mapping[str, Any]) -> ComplementSpread:
        try:
            return cls(tuple(tuple(float(v) for v in row) for row in record["cov"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise BeliefError(f"corrupt complement spread record ({exc}); re-save the belief.") from None


def _mixture_cdf(x: float, mu: np.ndarray, p: np.ndarray, s: float, lo: float, hi: float) -> float:
    """Σ_c p_c T_c(x), T_c the CDF of N(mu_c, s²) truncated to [lo, hi]."""
    a, b = ndtr((lo - mu) / s), ndtr((hi - mu) / s)
    mass = np.maximum(b - a, 1e-300)
    inside = np.clip((ndtr((min(max(x, lo), hi) - mu) / s) - a) / mass, 0.0, 1.0)
    thin = (b - a) < 1e-12
    inside = np.where(thin, (x >= np.clip(mu, lo, hi)).astype(float), inside)
    return float(p @ inside)


def complement_marginals(p: np.ndarray, theta: np.ndarray, spread: ComplementSpread, lower: np.ndarray,
                         upper: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(mean, std, lower quantile, upper quantile), each (D,), of Σ_c p_c N(θ_c, s_j²) truncated to the
    box, s_j = sqrt(cov_jj): every cell of a local belief spread by the complement's posterior."""
    keep = p > 1e-12 * p.max()
    p, theta = p[keep] / p[keep].sum(), theta[keep]
    out = np.empty((4, theta.shape[1]))
    for j, s in enumerate(spread.std):
        lo, hi, mu = float(lower[j]), float(upper[j]), np.clip(theta[:, j], lower[j], upper[j])
        if s <= 1e-12 * (hi - lo):
            order = np.argsort(mu, kind="stable")
            cdf = np.cumsum(p[order])
            quant = [mu[order][min(int(np.searchsorted(cdf, q)), mu.size - 1)] for q in (0.5 * (1 - level),
                                                                                        0.5 * (1 + level))]
            mean = float(p @ mu)
            out[:, j] = (mean, np.sqrt(max(float(p @ (mu - mean) ** 2), 0.0)), *quant)
            continue
        moments = np.array([_truncated(float(m), float(s), lo, hi) for m in mu])
        mean = float(p @ moments[:, 0])
        var = float(p @ (moments[:, 1] + (moments[:, 0] - mean) ** 2))
        quant = []
        for q in (0.5 * (1 - level), 0.5 * (1 + level)):
            a, b = lo, hi
            for _ in range(60):
                mid = 0.5 * (a + b)
                a, b = (a, mid) if _mixture_cdf(mid, mu, p, float(s), lo, hi) >= q else (mid, b)
            quant.append(b)
        out[:, j] = (mean, np.sqrt(max(var, 0.0)), *quant)
    return out[0], out[1], out[2], out[3]


def complement_draws(spread: ComplementSpread, theta: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                     rng: np.random.Generator) -> np.ndarray:
    """θ (n x D) of drawn cells plus a draw of the complement each, truncated to the box by rejection."""
    cov = np.asarray(spread.cov, dtype=float)
    values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
    root = vectors * np.sqrt(np.clip(values, 0.0, None))
    centre = np.clip(np.asarray(theta, dtype=float), lower, upper)
    out = centre.copy()
    todo = np.arange(len(centre))
    for _ in range(1000):
        if todo.size == 0:
            break
        draws = centre[todo] + rng.standard_normal((todo.size, centre.shape[1])) @ root.T
        inside = np.all((draws >= lower) & (draws <= upper), axis=1)
        out[todo[inside]] = draws[inside]
        todo = todo[~inside]
    return out
