"""The likelihood's scale σ² measured from the data: blocks for its size, the noise floor for adequacy.

The likelihood posterior weighs θ by exp(−E(θ)/(2σ²)). With K independent residuals of variance σ²
that is the likelihood; the residuals of a trajectory are neither independent (a state estimate
shares samples with its neighbours, model error is smooth in time) nor, under model error, noise.
Two questions fix σ², and the data answer both at the fitted θ̂ (the end of the local fit), from
the residuals r (K,) and their Jacobian J (K x D) in the unit box:

**How large is the spread the data show?** Cut the residuals into B blocks of consecutive samples
(``ScaleConfig.block`` samples, at least three autocorrelation times of the residuals), each
block's score g_b = J_bᵀ r_b (D,). The block sandwich covariance of θ̂ (White 1982; Huber 1967)

    Σ_sandwich = H⁻¹ M H⁻¹,    H = JᵀJ,   M = B/(B−1) Σ_b (g_b − ḡ)(g_b − ḡ)ᵀ

counts correlated residuals and blocks that disagree. The posterior's scale is matched to it in
the mean over the directions the data see (a learning rate of generalized Bayes chosen so that
the posterior's spread matches the estimator's, Holmes & Walker 2017; Lyddon, Holmes & Walker 2019):

    σ²_blocks = tr(H⁻¹ M) / D',   D' the eigen-directions of H above 1e-10 of the largest.

With independent noise of variance σ², E[M] = σ² H and σ²_blocks = σ² (on average): the iid rule.
The scale is never set below that rule's σ²_iid = E(θ̂)/(K − D): blocks that disagree widen the
posterior, but residuals whose noise cancels in the scores (a state estimated from the samples
around the compared one shares their noise) do not sharpen it beyond what independent noise would
give: E's minimum is neither exactly unbiased nor unimodal, and the independent value is the widest
the noise model itself justifies (docs/identification.md, "The likelihood's scale").

**Does the model explain the data?** The objective measures what the position noise alone leaves in
its residuals, s₀² per residual (physics.state_estimation: the noise measured from the recorded
positions, carried through the state estimate). The adequacy A = (E(θ̂)/K) / s₀² is 1 for a model
that fits to the noise. A bias shared by every block (another engine's contact law, a missing
effect) moves θ̂ without showing in the blocks' spread (on the foreign testbed the segments agree,
δ_seg 0-0.05, while θ* fits 13-70 % worse: docs/identification.md); it shows as A > 1. There the
relative discrepancy floor of :mod:`belief.noise` stays, in proportion to the share of E the noise
does not explain:

    δ = δ₀ · max(0, 1 − τ/A),     σ² = max(σ²_blocks, σ²_iid, δ E(θ̂)/2)

τ = ``ScaleConfig.tolerance`` (1.25) absorbs the noise estimate's own error and the state
estimate's deterministic error on smooth data; δ₀ = ``ScaleConfig.discrepancy`` (0.2, calibrated
on the foreign testbed). On data the model can produce, A ≈ 1, δ = 0 and the posterior has the
width of the data. When the objective cannot say what its noise leaves (s₀² unknown), δ = δ₀.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from belief.errors import BeliefError
from belief.noise import DEFAULT_DISCREPANCY, effective_size

__all__ = ["ScaleConfig", "Scale", "calibrated_scale", "block_scores"]


@dataclass(frozen=True)
class ScaleConfig:
    """block: samples per block (at least; raised to three autocorrelation times of the residuals);
    tolerance: τ, the adequacy up to which the model counts as explaining the data; discrepancy:
    δ₀, the relative excess error that costs one nat when the noise explains none of E."""

    block: int = 25
    tolerance: float = 1.25
    discrepancy: float = DEFAULT_DISCREPANCY

    def __post_init__(self) -> None:
        if isinstance(self.block, bool) or not isinstance(self.block, (int, np.integer)) or self.block < 2:
            raise BeliefError(f"ScaleConfig.block must be an integer >= 2 samples, got {self.block!r}.")
        if not (math.isfinite(self.tolerance) and self.tolerance >= 1.0):
            raise BeliefError(f"ScaleConfig.tolerance must be a ratio >= 1, got {self.tolerance!r}.")
        if not (math.isfinite(self.discrepancy) and self.discrepancy >= 0):
            raise BeliefError(f"ScaleConfig.discrepancy must be a fraction >= 0 of E, got {self.discrepancy!r}.")


@dataclass(frozen=True)
class Scale:
    """σ² (``noise_var``) and what set it: σ²_blocks, the noise floor s₀² (None: unknown), the adequacy
    A (None: unknown), δ, E(θ̂), K, the number of blocks B and directions D'."""

    noise_var: float
    blocks_var: float
    floor_var: float | None
    adequacy: float | None
    discrepancy: float
    error: float
    n_residuals: int
    n_blocks: int
    directions: int

    def as_dict(self) -> dict[str, float | int | None]:
        """JSON-able record (for a Belief's attrs)."""
        return dict(vars(self))

    @property
    def floor_set(self) -> bool:
        """Whether the model-error floor δ E(θ̂) / 2 set σ² (it then grows with E, so with more data)."""
        return self.discrepancy > 0 and self.noise_var >= 0.5 * self.discrepancy * self.error * (1 - 1e-9)

    def text(self) -> str:
        """One line for a summary: what set σ² and why."""
        if self.adequacy is None:
            fit = "the objective cannot say what its noise leaves"
        else:
            fit = (f"the best fit's residuals are {self.adequacy:.2f} times what the measured noise alone leaves")
        if self.floor_set:
            return (f"likelihood σ² = {self.noise_var:.4g}, set by model error: {fit}, so an error "
                    f"{100 * self.discrepancy:.0f}% above the best costs one nat (δ = {self.discrepancy:.3g}).")
        if self.noise_var > self.blocks_var:
            return (f"likelihood σ² = {self.noise_var:.4g}, that of independent residuals (the {self.n_blocks} "
                    f"blocks' spread gives {self.blocks_var:.4g}); {fit}.")
        return (f"likelihood σ² = {self.noise_var:.4g}, the spread of {self.n_blocks} blocks of residuals "
                f"(block sandwich); {fit}.")


def _blocks(residuals: Sequence[np.ndarray], block: int) -> list[tuple[int, int]]:
    """Row ranges (start, stop) of the flattened residual vector, per block of ``block`` samples;
    a segment's last short block joins the one before it."""
    out, offset = [], 0
    for r in residuals:
        rows, m = np.asarray(r).shape[0], int(np.asarray(r).shape[1]) if np.asarray(r).ndim == 2 else 1
        cuts = list(range(0, rows, block))
        if len(cuts) > 1 and rows - cuts[-1] < block // 2:
            cuts.pop()
        for k, start in enumerate(cuts):
            stop = cuts[k + 1] if k + 1 < len(cuts) else rows
            out.append((offset + start * m, offset + stop * m))
        offset += rows * m
    return out


def block_scores(residuals: Sequence[np.ndarray], jacobian: np.ndarray, *, block: int) -> np.ndarray:
    """g_b = J_bᵀ r_b (B x D) of consecutive blocks of ``block`` samples; ``residuals``: the S segments
    (T_s x m, NaN rows not compared), ``jacobian``: K x D with K = Σ T_s m rows in the same order."""
    r = np.nan_to_num(np.concatenate([np.ravel(np.asarray(s, dtype=float)) for s in residuals]), nan=0.0)
    J = np.asarray(jacobian, dtype=float)
    if J.ndim != 2 or J.shape[0] != r.size:
        raise BeliefError(f"the Jacobian has shape {J.shape}; the residuals have {r.size} entries (one row each).")
    return np.array([J[a:b].T @ r[a:b] for a, b in _blocks(residuals, block)])


def calibrated_scale(residuals: Sequence[np.ndarray], jacobian: np.ndarray, *, noise_floor: float | None,
                     config: ScaleConfig = ScaleConfig(), least: float = 0.0) -> Scale:
    """σ² of the likelihood from the residuals (S segments, T_s x m) at the fitted θ̂ and their
    Jacobian (K x D, unit box), and s₀² = ``noise_floor`` (per residual, or None); module docstring.
    ``least``: the smallest σ² returned (an exact fit of noise-free data leaves σ² = 0, which no
    likelihood can use; callers pass 1e-12 x the median error, as the "iid" rule floors)."""
    flat = np.concatenate([np.ravel(np.asarray(s, dtype=float)) for s in residuals])
    finite = np.isfinite(flat)
    K = int(finite.sum())
    if K == 0:
        raise BeliefError("calibrated_scale: every residual is NaN; nothing was compared.")
    error = float(np.sum(flat[finite] ** 2))
    tau = max(effective_size(residuals).tau)
    scores = block_scores(residuals, jacobian, block=max(int(config.block), int(math.ceil(3 * tau))))
    B = scores.shape[0]
    J = np.nan_to_num(np.asarray(jacobian, dtype=float))
    values, vectors = np.linalg.eigh(J.T @ J)
    keep = values > 1e-10 * max(float(values.max()), 1e-300)
    if B < 2 or not keep.any():
        blocks_var = error / max(K - J.shape[1], 1)
    else:
        centred = scores - scores.mean(axis=0)
        meat = B / (B - 1) * centred.T @ centred
        along = np.einsum("dk,de,ek->k", vectors[:, keep], meat, vectors[:, keep])
        blocks_var = float(np.sum(along / values[keep]) / keep.sum())
    adequacy = None
    delta = float(config.discrepancy)
    if noise_floor is not None and noise_floor > 0:
        adequacy = (error / K) / float(noise_floor)
        delta = float(config.discrepancy) * max(0.0, 1.0 - config.tolerance / adequacy)
    iid_var = error / max(K - J.shape[1], 1)
    noise_var = max(blocks_var, iid_var, 0.5 * delta * error, float(least), 1e-300)
    return Scale(noise_var, blocks_var, None if noise_floor is None else float(noise_floor), adequacy, delta, error,
                 K, B, int(keep.sum()))
