"""E's own curvature at the local fit, measured by E itself rather than read off its Jacobian.

The Gauss-Newton information F = JᵀJ/σ² is the curvature of L = E/(2σ²) − log p_measured only
where the predictions are linear in θ over the posterior's extent. On the T6 they are not: the
contacts and the cables' slack make E rise far less than F says along some combinations (on an
own-engine robot at 1 mm of noise, a straight move that F prices at 43 nats costs under one), so
the Laplace approximation is sharp in the wrong places. Here the curvature is measured where the
posterior lives: in the whitened coordinates z of the pinned directions (u = û + W z, W = V_p
diag(s), s_k = (λ_k + π_k)^−½, one posterior sd), L at the centre, at ± r e_k and at r (e_k + e_l)
gives, by finite differences at that scale,

    A_kk = (L(+r e_k) + L(−r e_k) − 2 L(0)) / r²,   A_kl = (L(r e_k + r e_l) − L(r e_k) − L(r e_l) + L(0)) / r²

(1 + 2P + P(P − 1)/2 evaluations in one batch for P pinned directions). F's own curvature there
is A_F = diag(λ_k / (λ_k + π_k)). The measured one may only lower it: with
M = A_F^−½ A A_F^−½, its eigenvalues are clipped to [10⁻⁶, 1] (a direction where E rises more
than F says keeps F's width, one where E falls or stays flat keeps the prior's), and
A' = A_F^½ M' A_F^½ replaces the pinned part of F. A probe that fails keeps F's entries.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from belief.errors import BeliefError
from physics.measurements import MeasurementPrior
from physics.objective import Objective

__all__ = ["PRIOR_PRECISION", "Curvature", "secant_information", "prior_precision"]

#: precision of the uniform prior over the unit interval (its variance is 1/12)
PRIOR_PRECISION = 12.0


def prior_precision(vectors: np.ndarray) -> np.ndarray:
    """π_k = 12 max_j v_kj² (D,): the uniform prior's precision along each unit column v_k, which
    spreads over the chord 1/max_j |v_kj| through the box."""
    return PRIOR_PRECISION * np.max(np.asarray(vectors) ** 2, axis=0)


@dataclass(frozen=True)
class Curvature:
    """information (D x D, unit box): F with its pinned part measured by E; ratio (P,): the
    eigenvalues of M' (1 where E agrees with F, below where E is flatter); evaluations spent."""

    information: np.ndarray
    ratio: np.ndarray
    evaluations: int


def _probes(P: int, r: float) -> np.ndarray:
    """z of the module docstring's probes (1 + 2P + P(P−1)/2, P): centre, ± r e_k, r (e_k + e_l)."""
    eye = np.eye(P)
    pairs = [eye[k] + eye[m] for k in range(P) for m in range(k + 1, P)]
    return np.vstack([np.zeros((1, P)), r * eye, -r * eye, r * np.array(pairs).reshape(-1, P)])


def _secant(values: np.ndarray, P: int, r: float) -> np.ndarray:
    """A (P x P) from L at the probes of :func:`_probes` (NaN where a probe failed)."""
    L0, plus, minus = values[0], values[1:1 + P], values[1 + P:1 + 2 * P]
    A = np.diag((plus + minus - 2 * L0) / r ** 2)
    pair = iter(values[1 + 2 * P:])
    for k in range(P):
        for m in range(k + 1, P):
            A[k, m] = A[m, k] = (next(pair) - plus[k] - plus[m] + L0) / r ** 2
    return A


def _bounded(A: np.ndarray, a_F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A' (P x P), eigenvalues of M') with 0 < A' ≤ diag(a_F): F's entries where A is NaN."""
    root = np.sqrt(a_F)
    M = A / np.outer(root, root)
    M = np.where(np.isfinite(M), M, np.eye(a_F.size))
    ratio, vectors = np.linalg.eigh(0.5 * (M + M.T))
    ratio = np.clip(ratio, 1e-6, 1.0)
    return (vectors * ratio) @ vectors.T * np.outer(root, root), ratio


def secant_information(objective: Objective, centre: np.ndarray, information: np.ndarray, noise_var: float, *,
                       reach: float = 2.0, prior: MeasurementPrior | None = None) -> Curvature:
    """The module docstring's measured information at ``centre`` (D,, unit box) from F (D x D, unit
    box: JᵀJ/σ² + GᵀG) and σ², probes ``reach`` posterior sds out; ``prior``: what the user measured
    (in L as in F)."""
    if not (np.isfinite(reach) and reach > 0):
        raise BeliefError(f"secant_information needs reach > 0 posterior sds, got {reach!r}.")
    F = 0.5 * (information + information.T)
    lam, V = np.linalg.eigh(F)
    pinned = lam > prior_precision(V)
    P = int(pinned.sum())
    if P == 0:
        return Curvature(F, np.ones(0), 0)
    lam_p, V_p = lam[pinned], V[:, pinned]
    s = 1.0 / np.sqrt(lam_p + prior_precision(V_p))
    us = np.clip(centre[None] + _probes(P, reach) @ (V_p * s).T, 0.0, 1.0)
    space = objective.space
    thetas = space.lower + (space.upper - space.lower) * us
    batch = objective.evaluate_batch(thetas)
    values = np.asarray(batch.errors, dtype=float) / (2.0 * float(noise_var))
    if prior is not None and prior.measurements:
        values = values - prior.log_density(thetas)
    if not np.isfinite(values[0]):
        return Curvature(F, np.ones(P), len(us))
    A, ratio = _bounded(_secant(values, P, reach), lam_p * s ** 2)
    W_plus = V_p / s                                     # u-space rows of W⁺ = diag(1/s) V_pᵀ, as columns
    measured = W_plus @ A @ W_plus.T
    return Curvature(F - (V_p * lam_p) @ V_p.T + measured, ratio, len(us))
