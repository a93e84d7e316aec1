"""Active identification: choose the flop whose outcome is expected to shrink P the most, run it on
the robot, update P, repeat.

Hypotheses. P is represented on M cells: ``how="sample"`` draws M cells i.i.d. from P and weighs
each distinct cell by its count / M (a Monte Carlo picture of P), ``how="top"`` keeps the M most
probable cells with weights ∝ P. Probing only re-weighs these cells; every other cell gets P = 0.

Observation model. A probe's observation y is the sensed node trajectory of the flop, recorded
at ``rate`` Hz and flattened (d = T·36 numbers [m]). Under cell i the simulator predicts f_i
(:mod:`planners.rollouts`, from the robot's sensed start) and

    y | i ~ N(f_i, s² I),   s² = σ² · d / d_eff

σ [m] is the noise per coordinate (sensor noise plus model error). The predictions of nearby
cells differ by smooth, rigid motions, so the d coordinates carry far fewer independent numbers;
d_eff is their effective count, the mean over cells of belief.noise.effective_size of the
deviation f_i − f̄ (time along rows, 36 coordinates): the tempering of belief's "ess" noise rule,
applied to the rollout. A cell whose simulation diverged predicts the event "diverged" (infinitely
far from every trajectory).

Expected information gain (the expected entropy reduction of P on the M cells) of an action,
by the pairwise-distance estimator of Kolchinsky & Tracey (2017) with the Bhattacharyya distance
between the Gaussians of cells i and j, B_ij = ‖f_i − f_j‖² / (8 s²)::

    EIG = I(cell; y) ≈ − Σ_i w_i log Σ_j w_j exp(−B_ij)                 [nats]

It is a lower bound on the mutual information, 0 when all predictions agree and H(w) when all
are far apart; it needs no noise draws (deterministic). Update after observing y (Bayes)::

    w_i ← w_i exp(−‖y − f_i‖² / (2 s²)) / Σ_j w_j exp(−‖y − f_j‖² / (2 s²))

Stopping rule (checked after each step): every parameter in ``targets`` has the verdict
"identified" (belief.default_verdicts on the updated P), or no candidate's EIG exceeds
``min_gain`` (checked before acting), or ``steps`` probes were made.

Verdicts on the probed cells: P lives on M cells drawn from the belief, so when the weights rest
on fewer than ``MIN_CELLS`` effective cells (n_eff = 1 / Σ w_i²) its spread says which cell is
closest to the truth, not how well a parameter is known: every parameter is then "not
identified" (the interval would be a cell's point, not a credible region).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.special import logsumexp
from tqdm.auto import tqdm

from belief.belief import Belief
from belief.noise import effective_size
from physics.pool import DaskPool
from planners.actions import FlopAction, candidate_actions
from planners.errors import EmptyBeliefError, PlannerError
from planners.robot import SimulatedRobot
from planners.rollouts import RolloutSet, check_belief, pool_for, rollouts

#: fewer effective probed cells than this and no parameter is "identified" (module docstring)
MIN_CELLS = 3

__all__ = ["support", "observations", "noise_scale", "information_gain", "update_weights", "probe_actions",
           "restricted_belief", "ProbeStep", "ProbeRun", "probe"]


def support(belief: Belief, n: int, *, seed: int, how: str = "sample") -> tuple[np.ndarray, np.ndarray]:
    """(cell indices ``M``, weights ``M`` summing to 1) representing P (module docstring)."""
    check_belief(belief)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise EmptyBeliefError(f"cells must be an integer >= 1 (hypotheses to probe with), got {n!r}.")
    p = np.asarray(belief.p, dtype=float)
    if how == "sample":
        idx, counts = np.unique(belief.sample_cells(int(n), seed=seed), return_counts=True)
        return idx.astype(np.int64), counts / counts.sum()
    if how == "top":
        idx = np.sort(np.argsort(-p, kind="stable")[: min(int(n), p.size)])
        idx = idx[p[idx] > 0]
        return idx.astype(np.int64), p[idx] / p[idx].sum()
    raise PlannerError(f"how must be 'sample' (draw cells from P) or 'top' (most probable cells), got {how!r}.")


def observations(rs: RolloutSet) -> tuple[np.ndarray, np.ndarray]:
    """(predictions ``n_a x M x d`` [m], ok ``n_a x M``) from the recorded nodes of a rollout set."""
    ok = rs.ok
    size = max(o.nodes.size for row in rs.outcomes for o in row)
    F = np.array([[o.nodes.reshape(-1) if o.ok else np.zeros(size) for o in row] for row in rs.outcomes])
    return np.nan_to_num(F), ok


def noise_scale(F: np.ndarray, ok: np.ndarray, sigma: float) -> float:
    """s² = σ² d / d_eff [m²] for the predictions ``M x d`` of one action (module docstring)."""
    good = F[ok]
    d = F.shape[1]
    if good.shape[0] < 2:
        return sigma ** 2
    dev = good - good.mean(axis=0)
    n_eff = [effective_size([row.reshape(-1, 36)]).n_eff for row in dev if np.any(row != 0)]
    d_eff = float(np.clip(np.mean(n_eff), 1.0, d)) if n_eff else float(d)
    return sigma ** 2 * d / d_eff


def _distances(F: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """‖f_i − f_j‖² ``M x M``; inf between a diverged and an ok cell, 0 between two diverged."""
    sq = np.sum(F ** 2, axis=1)
    D = np.maximum(sq[:, None] + sq[None, :] - 2.0 * F @ F.T, 0.0)
    D[ok[:, None] != ok[None, :]] = np.inf
    D[~ok[:, None] & ~ok[None, :]] = 0.0
    return D


def information_gain(F: np.ndarray, ok: np.ndarray, weights: np.ndarray, s2: float) -> float:
    """EIG ≈ −Σ_i w_i log Σ_j w_j exp(−‖f_i − f_j‖²/(8 s²)) [nats] for predictions ``M x d`` (module docstring)."""
    w = np.asarray(weights, dtype=float)
    B = _distances(np.asarray(F, dtype=float), np.asarray(ok, dtype=bool)) / (8.0 * s2)
    inner = logsumexp(-B, b=w[None, :], axis=1)
    return float(max(-(w * inner).sum(), 0.0))


def update_weights(weights: np.ndarray, F: np.ndarray, ok: np.ndarray, y: np.ndarray, y_ok: bool,
                   s2: float) -> np.ndarray:
    """w_i ∝ w_i exp(−‖y − f_i‖²/(2 s²)) (``y``: observation ``d``); cells whose status differs from the
    robot's get 0. If no cell agrees with the robot's status, w is returned unchanged."""
    w = np.asarray(weights, dtype=float)
    same = np.asarray(ok, dtype=bool) == bool(y_ok)
    if not same.any():
        return w.copy()
    r2 = np.sum((np.asarray(F, dtype=float) - np.nan_to_num(np.asarray(y, dtype=float).reshape(-1))) ** 2, axis=1)
    logw = np.where(same & (w > 0), np.log(np.where(w > 0, w, 1.0)) - (r2 if y_ok else 0.0) / (2.0 * s2), -np.inf)
    return np.exp(logw - logsumexp(logw))


def probe_actions(nodes: np.ndarray, *, changes: Sequence[float] = (0.2, 0.3), n_cables: Sequence[int] = (2, 4),
                  duration: float = 1.5) -> tuple[FlopAction, ...]:
    """Default probing candidates: the three edges of the resting face x ``changes`` x ``n_cables``,
    change held 0.2-1.0 s, observed ``duration`` s (varying the actuation, not only the edge)."""
    return candidate_actions(nodes=nodes, changes=changes, n_cables=n_cables, stop=1.0, duration=duration)


def restricted_belief(belief: Belief, cells: np.ndarray, weights: np.ndarray) -> Belief:
    """``belief`` with P = ``weights`` on ``cells`` and 0 elsewhere; verdicts from P alone, none
    "identified" when the weights rest on fewer than ``MIN_CELLS`` effective cells (module docstring)."""
    p = np.zeros(belief.n_cells)
    p[np.asarray(cells)] = weights
    p /= p.sum()
    kwargs = dict(decoder_config=belief.decoder_config, grid_config=belief.grid_config, level=belief.level,
                  attrs={**belief.attrs, "probed_cells": int(len(cells))})
    n_eff = 1.0 / float(np.sum(p ** 2))
    if n_eff >= MIN_CELLS:
        return Belief(p, belief.theta, belief.space, **kwargs)
    reason = (f"P rests on {n_eff:.1f} effective cells of the {len(cells)} probed (fewer than {MIN_CELLS}): it says "
              "which cell is closest, not how well this parameter is known; identify again with the new data")
    return Belief(p, belief.theta, belief.space, verdicts=["not identified"] * belief.space.dim,
                  reasons=[reason] * belief.space.dim, **kwargs)


@dataclass(frozen=True)
class ProbeStep:
    """One probe: the ``action`` run, the EIG of every candidate ``gains`` [nats] and the chosen one's
    ``gain``, the entropy of the weights before and after [nats], the ``weights`` after (``M``),
    the verdicts after (name -> verdict), the robot's outcome status."""

    action: FlopAction
    gain: float
    gains: np.ndarray
    entropy_before: float
    entropy_after: float
    weights: np.ndarray = field(repr=False)
    verdicts: dict[str, str] = field(repr=False)
    status: str = "ok"


@dataclass(frozen=True)
class ProbeRun:
    """A probing run: ``steps``, the ``cells`` probed (``M``), the final ``belief``, why it ``stopped``."""

    steps: tuple[ProbeStep, ...]
    cells: np.ndarray
    initial_weights: np.ndarray
    belief: Belief
    stopped: str


def _entropy(w: np.ndarray) -> float:
    w = w[w > 0]
    return float(-(w * np.log(w)).sum())


def _choose(gains: np.ndarray, choose: str, rng: np.random.Generator) -> int:
    if choose == "gain":
        return int(np.argmax(gains))
    return int(rng.integers(len(gains)))


def probe(belief: Belief, robot: SimulatedRobot | np.ndarray | None, *, steps: int = 4, cells: int = 16,
          sigma: float = 0.02, seed: int = 0, how: str = "sample", min_gain: float = 0.05,
          targets: Sequence[str] = (), actions: Sequence[FlopAction] | None = None, choose: str = "gain",
          duration: float = 1.5, actions_kw: dict | None = None, pool: DaskPool | None = None,
          n_workers: int = 0, progress: bool = True) -> ProbeRun:
    """Probe ``robot`` (SimulatedRobot, or θ* to build one) up to ``steps`` times (module docstring).

    ``cells``/``how``/``seed``: the hypotheses; ``sigma`` [m]; ``targets``: parameter names that must
    be identified to stop; ``actions``: fixed candidates (default :func:`probe_actions` on each new
    face, ``duration`` s, options ``actions_kw``); ``choose``: "gain" (active) or "random" (uniform
    among the candidates, seeded).
    """
    idx, w0 = support(belief, cells, seed=seed, how=how)
    unknown = sorted(set(targets) - set(belief.space.names))
    if unknown or choose not in ("gain", "random") or not (np.isfinite(sigma) and sigma > 0):
        raise PlannerError(f"probe needs targets among {list(belief.space.names)} (unknown: {unknown}), choose 'gain' "
                           f"or 'random' (got {choose!r}) and sigma > 0 m (got {sigma!r}).")
    robot = robot if isinstance(robot, SimulatedRobot) else SimulatedRobot(robot, noise=1e-3, seed=seed)
    rng, w, out_steps, stopped = np.random.default_rng(seed), w0.copy(), [], "steps"
    pool, own = pool_for(pool, n_workers)
    try:
        for _ in tqdm(range(int(steps)), desc="probe", disable=not progress, leave=False):
            st = robot.observe()
            acts = tuple(actions) if actions is not None else \
                probe_actions(st.nodes, duration=duration, **(actions_kw or {}))
            if choose == "random":      # roll out only the drawn action
                acts = (acts[int(rng.integers(len(acts)))],)
            rs = rollouts(acts, st, belief.theta[idx], pool=pool)
            F, ok = observations(rs)
            s2 = [noise_scale(F[a], ok[a], sigma) for a in range(len(acts))]
            gains = np.array([information_gain(F[a], ok[a], w, s2[a]) for a in range(len(acts))])
            if choose == "gain" and gains.max() <= min_gain:
                stopped = "no gain"
                break
            a = _choose(gains, choose, rng)
            outcome = robot.execute(acts[a], rs.plans[a])
            h0, w = _entropy(w), update_weights(w, F[a], ok[a], outcome.nodes, outcome.ok, s2[a])
            b = restricted_belief(belief, idx, w)
            out_steps.append(ProbeStep(acts[a], float(gains[a]), gains, h0, _entropy(w), w.copy(),
                                       dict(zip(b.space.names, b.verdict, strict=True)), outcome.status))
            if targets and all(b.verdicts[t][0] == "identified" for t in targets):
                stopped = "identified"
                break
    finally:
        if own:
            pool.close()
    return ProbeRun(tuple(out_steps), idx, w0, restricted_belief(belief, idx, w), stopped)
