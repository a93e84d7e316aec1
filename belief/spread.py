"""The local spread of the best evaluated cell: P's mass there is not a point.

P lives on cells, and a cell's decoded θ_c is a point. When one cell holds most of P (a warm
start far better than anything the search found, low-noise data, a coarse grid in many
dimensions), every quantile of a marginal is θ_cj and the credible interval has zero width: the
width of the grid's resolution, not of the data. At the best evaluated cell the "local width"
rule (belief.verdicts) measures the data's own width, the Laplace std of the Gauss-Newton step,
s_j = sqrt diag (JᵀJ/σ²)⁻¹ (belief.least_squares). The marginal of θ_j is then the mixture

    F_j(x) = Σ_{k≠c} p_k 1[θ_kj <= x] + p_c T_j(x),

T_j the normal N(θ_cj, s_j²) truncated to the box [lower_j, upper_j]. The credible interval is
its (1 − level)/2 and (1 + level)/2 quantiles; mean and std are its moments. Only the best cell
gets a spread: it is the one whose curvature was measured, and the one whose mass makes the
intervals collapse. Draws (``Belief.sample``) stay on cell centres, because a spread per parameter
ignores the correlations of the local posterior that joint draws would need.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import ndtr

from belief.errors import BeliefError

__all__ = ["CellSpread", "spread_marginals"]


@dataclass(frozen=True)
class CellSpread:
    """The local std ``std`` (D,) in θ units of cell ``cell`` (an index into P's cells); ``inf``
    for a direction the data do not see (uniform over the box), 0 for a point."""

    cell: int
    std: tuple[float, ...]

    def __post_init__(self) -> None:
        s = np.asarray(self.std, dtype=float)
        if isinstance(self.cell, bool) or not isinstance(self.cell, (int, np.integer)) or self.cell < 0:
            raise BeliefError(f"CellSpread.cell must be a cell index >= 0, got {self.cell!r}.")
        if s.ndim != 1 or np.any(np.isnan(s)) or np.any(s < 0):
            raise BeliefError(f"CellSpread.std must be a vector of stds >= 0 (inf allowed), got {self.std!r}.")
        object.__setattr__(self, "cell", int(self.cell))
        object.__setattr__(self, "std", tuple(float(v) for v in s))

    def as_dict(self) -> dict[str, Any]:
        """JSON-able form (inf as the string "inf")."""
        return {"cell": self.cell, "std": [v if np.isfinite(v) else "inf" for v in self.std]}

    @classmethod
    def from_dict(cls, record: Mapping[str, Any]) -> CellSpread:
        """Inverse of :meth:`as_dict`."""
        try:
            return cls(int(record["cell"]), tuple(float(v) for v in record["std"]))
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
        mu, s = float(np.clip(theta[c, j], lo, hi)), spread.std[j]
        m_t, v_t = _truncated(mu, s, lo, hi)
        mean = float(p[rest] @ theta[rest, j]) + w * m_t
        var = float(p[rest] @ (theta[rest, j] - mean) ** 2) + w * (v_t + (m_t - mean) ** 2)
        order = np.argsort(theta[rest, j], kind="stable")
        values, cdf = theta[rest, j][order], np.cumsum(p[rest][order])
        atom = (w, mu, s, lo, hi)
        out[:, j] = (mean, np.sqrt(max(var, 0.0)), _quantile(values, cdf, atom, 0.5 * (1 - level)),
                     _quantile(values, cdf, atom, 0.5 * (1 + level)))
    return out[0], out[1], out[2], out[3]
