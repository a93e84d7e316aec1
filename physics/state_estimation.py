"""The state a prediction starts from: node positions and velocities estimated from noisy samples.

A one-step prediction f(x_i, v_i, u_i, θ) starts from a state rebuilt from the recorded node
positions. When the data carry no velocities they are estimated, and that estimate carries the
measurement noise into the prediction. The error E(θ) = Σ ||x_{i+1} − f(x̂_i, v̂_i, u_i, θ)||² is
then an errors-in-variables problem: its expectation over the noise is

    E_noise-free(θ) + Σ_i E||f(s_i + η_i, θ) − f(s_i, θ)||² + const,

and the middle term depends on θ. Parameters that damp the motion (cable damping, stiffness
against pretension) shrink how far the state's noise η_i travels, so they lower E without fitting
the motion better: the minimum of E moves away from θ* by an amount that grows with the noise
variance of the state (Fuller, *Measurement Error Models*, 1987, ch. 1). The second-order
backward difference v_i = (3x_i − 4x_{i−1} + x_{i−2}) / (2Δ) multiplies the position noise σ by
√26/2 ≈ 2.55 per Δ: 0.25 m/s at 1 mm and 100 Hz, which moves a node 2.5 mm in one step.

``"local-polynomial"`` (the default) fits a polynomial of ``degree`` in time, by least squares, to
the samples around i that the prediction is *not* compared with (Savitzky & Golay 1964, with a
gap): ``half_width`` samples up to and including i, and ``half_width`` samples after the compared
ones (i + ahead + 1 ...), where ``ahead`` is how many samples the prediction from i is compared
with (1 for the one-step error). The fit's value and slope at i are the state. The compared
samples' own noise never enters the state they are compared with, and the state's noise is small:
with the defaults (6 samples up to i and 6 after i + 1, cubic) the velocity noise is 0.18 σ/Δ (14
times smaller than the backward difference's, 200 times in variance) and the position noise 0.48 σ.
The price is a deterministic error where the motion is not locally cubic (an impact); on
noise-free flops it moves the minimum of E by a fraction of the local width at 1 mm of noise
(docs/identification.md, benchmarks/objective_bias.py).

``"backward"`` is the second-order backward difference (first order where x_{i−2} is missing), with
the recorded positions as they are: the paper's one-step error. Its truncation error is smaller
(it spans 3 samples, not 13), so on noise-free positions (simulated data without velocities) it
gives the sharper objective; recorded motion always carries noise.

Samples that are NaN are left out of a fit; a state whose fit has fewer than ``degree + 2``
samples, or whose own sample is missing, cannot be rebuilt (NaN).

**What the noise alone leaves** (:meth:`StateEstimator.noise_floor`). The position noise σ is
measured from the data: each sample is compared with the cubic through its three neighbours on
either side (itself left out), e_i = x_i − Σ_k w_k x_{i+k}, whose variance is σ² (1 + ||w||²) for
white noise; a median over all coordinates and samples keeps impacts, where the motion is not
locally cubic, out of it (σ² = median(e²) / (0.4549 (1 + ||w||²)), 0.4549 the median of χ²₁).
A prediction compared a samples ahead then differs from the recorded sample by the sample's own
noise and by the state's noise carried over the step: to first order (the motion over one
interval is kinematic) the state's fit extrapolated to offset a, with weights w(a), so the
residual variance per coordinate is σ² (1 + ||w(a)||²), averaged over a = 1 .. ahead. This is the
floor an adequate model meets at its best fit: E(θ̂)/K well above it means the model lacks
something the data show (belief.scale).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from physics.errors import ParameterError

__all__ = ["StateEstimator", "DEFAULT_STATES", "STATE_METHODS", "position_noise"]

#: median of the χ² distribution with one degree of freedom
_CHI2_1_MEDIAN = 0.45493642311957283

#: the ways a state is estimated from positions alone (module docstring)
STATE_METHODS = ("local-polynomial", "backward")


@dataclass(frozen=True)
class StateEstimator:
    """How node positions and velocities are estimated from recorded positions (module docstring).

    method: "local-polynomial" or "backward"; half_width: samples on each side of the gap (local
    polynomial); degree: the polynomial's degree (1-3)."""

    method: Literal["local-polynomial", "backward"] = "local-polynomial"
    half_width: int = 6
    degree: int = 3

    def __post_init__(self) -> None:
        if self.method not in STATE_METHODS:
            raise ParameterError(f"StateEstimator.method must be one of {STATE_METHODS}, got {self.method!r}.")
        if isinstance(self.degree, bool) or self.degree not in (1, 2, 3):
            raise ParameterError(f"StateEstimator.degree must be 1, 2 or 3, got {self.degree!r}.")
        if isinstance(self.half_width, bool) or not isinstance(self.half_width, (int, np.integer)) \
                or not 2 <= self.half_width <= 20 or 2 * self.half_width < self.degree + 2:
            raise ParameterError(f"StateEstimator.half_width must be an integer in [2, 20] with 2 x half_width >= "
                                 f"degree + 2, got {self.half_width!r} (degree {self.degree}).")

    def config(self) -> dict[str, str | int]:
        """JSON-able record, for an objective's fingerprint."""
        if self.method == "backward":
            return {"method": self.method}
        return {"method": self.method, "half_width": int(self.half_width), "degree": int(self.degree)}

    def estimate(self, nodes: np.ndarray, interval: float, *, ahead: int | None = 1) -> tuple[np.ndarray, np.ndarray]:
        """(positions, velocities), each T x 12 x 3 [m, m/s], of the states the predictions start from.

        nodes: recorded positions (T x 12 x 3, NaN where missing); interval: Δ [s]; ahead: samples
        the prediction from i is compared with (they are left out of its state), None for a free
        rollout (only samples up to i are used)."""
        x = np.asarray(nodes, dtype=float)
        if self.method == "backward":
            return x, _backward(x, interval)
        past = np.arange(-self.half_width + 1, 1)
        future = np.arange(ahead + 1, ahead + 1 + self.half_width) if ahead is not None else np.empty(0, int)
        return _local_polynomial(x, interval, np.concatenate([past, future]), self.degree)

    def noise_floor(self, nodes: np.ndarray, interval: float, *, ahead: int = 1) -> float:
        """σ² (1 + mean_a ||w(a)||²) [m²]: the residual variance per coordinate that the position noise
        σ (:func:`position_noise`) alone leaves in predictions compared 1 .. ``ahead`` samples after
        their state (module docstring); recorded velocities are not covered (they carry no σ)."""
        sigma2 = position_noise(nodes) ** 2
        if self.method == "backward":
            gains = [float(np.sum(_backward_extrapolation(a) ** 2)) for a in range(1, ahead + 1)]
        else:
            past = np.arange(-self.half_width + 1, 1, dtype=float)
            future = np.arange(ahead + 1, ahead + 1 + self.half_width, dtype=float)
            offsets = np.concatenate([past, future])
            fit = np.linalg.pinv(np.vander(offsets, self.degree + 1, increasing=True))
            gains = [float(np.sum((np.vander(np.array([a], float), self.degree + 1, increasing=True)[0] @ fit) ** 2))
                     for a in range(1, ahead + 1)]
        return sigma2 * (1.0 + float(np.mean(gains)))


def position_noise(nodes: np.ndarray) -> float:
    """σ [m]: the white position noise of recorded nodes (T x 12 x 3, NaN allowed), from the
    residuals of the leave-one-out cubic through the three samples on either side (module docstring)."""
    x = np.asarray(nodes, dtype=float)
    offsets = np.array([-3, -2, -1, 1, 2, 3], dtype=float)
    weights = np.linalg.pinv(np.vander(offsets, 4, increasing=True))[0]
    if len(x) < 7:
        return 0.0
    centre = x[3:-3]
    fit = sum(w * x[3 + int(o):len(x) - 3 + int(o)] for w, o in zip(weights, offsets, strict=True))
    e2 = (centre - fit) ** 2
    e2 = e2[np.isfinite(e2)]
    if e2.size == 0:
        return 0.0
    return float(np.sqrt(np.median(e2) / (_CHI2_1_MEDIAN * (1.0 + float(weights @ weights)))))


def _backward_extrapolation(a: int) -> np.ndarray:
    """Weights on (x_i, x_{i−1}, x_{i−2}) of x_i + a Δ v_i with the backward-difference velocity."""
    return np.array([1.0 + 1.5 * a, -2.0 * a, 0.5 * a])


#: the estimator TrajectoryObjective uses unless told otherwise
DEFAULT_STATES = StateEstimator()


def _backward(x: np.ndarray, interval: float) -> np.ndarray:
    """v_i = (3 x_i − 4 x_{i−1} + x_{i−2}) / (2Δ), first order (x_i − x_{i−1}) / Δ where that is NaN."""
    vel = np.full_like(x, np.nan)
    vel[2:] = (3 * x[2:] - 4 * x[1:-1] + x[:-2]) / (2 * interval)
    first = (x[1:] - x[:-1]) / interval
    fill = ~np.isfinite(vel[1:]).all(axis=(1, 2))
    vel[1:][fill] = first[fill]
    return vel


def _local_polynomial(x: np.ndarray, interval: float, offsets: np.ndarray, degree: int
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Value and slope at offset 0 of the least-squares polynomial of ``degree`` through the finite
    samples x_{i+o}, o in ``offsets``, for every i; one weight vector per pattern of missing samples."""
    T = len(x)
    finite = np.isfinite(x).all(axis=(1, 2))
    index = np.arange(T)[:, None] + offsets[None, :]
    inside = (index >= 0) & (index < T)
    present = inside & finite[np.clip(index, 0, T - 1)]
    positions, velocities = np.full_like(x, np.nan), np.full_like(x, np.nan)
    usable = finite & (present.sum(axis=1) >= degree + 2)
    patterns, which = np.unique(present[usable], axis=0, return_inverse=True)
    rows = np.flatnonzero(usable)
    for k, pattern in enumerate(patterns):
        offs = offsets[pattern]
        weights = np.linalg.pinv(np.vander(offs.astype(float), degree + 1, increasing=True))
        members = rows[np.ravel(which) == k]
        window = x[index[members][:, pattern]]                      # n x m x 12 x 3
        positions[members] = np.einsum("m,nmij->nij", weights[0], window)
        velocities[members] = np.einsum("m,nmij->nij", weights[1], window) / interval
    return positions, velocities
