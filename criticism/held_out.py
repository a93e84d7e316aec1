"""How a model scores on held-out trajectories, and where its residual lives there.

Three scores per trajectory k at θ (:func:`held_scores`): the one-step error
Σ_i ||x_{i+1} − f(x_i, u_i, θ)||² [m²] (horizon 1, every prediction from an observed state), the
objective's windowed error [m²] (its horizon), and the open-loop drift [m], the mean node distance
of one free rollout from the first sample at a given time. :func:`localize` says where the one-step
residual lives: shares by phase, the top nodes, shares by axis (criticism.residuals) and the share
of its power per frequency band (FREQUENCY_BANDS).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from criticism.residuals import residual_dataset, residual_summary
from physics.errors import PhysicsError
from physics.trajectory_objective import TrajectoryObjective

__all__ = ["HeldScores", "held_scores", "one_step_error", "localize", "where_text", "FREQUENCY_BANDS"]

#: Edges [Hz] of the frequency bands of :func:`localize` (the last band runs to the Nyquist frequency).
FREQUENCY_BANDS: tuple[float, ...] = (0.0, 1.0, 5.0, 15.0)


@dataclass(frozen=True)
class HeldScores:
    """Per held-out trajectory ("t{k}"): one-step error Σ||r||² [m²], the objective's windowed error
    [m²], and the open-loop drift [m] at the configured time."""

    one_step: dict[str, float]
    windows: dict[str, float]
    drift: dict[str, float]

    def totals(self) -> dict[str, float]:
        """Summed one-step and windowed errors, and the mean drift."""
        return {"one_step": sum(self.one_step.values()), "windows": sum(self.windows.values()),
                "drift": float(np.mean(list(self.drift.values()))) if self.drift else float("nan")}


def where_text(where: dict[str, Any]) -> str:
    """One line from :func:`localize`: shares by phase, the top nodes, shares by axis and frequency band."""
    phases = ", ".join(f"{k} {v['share']:.0%}" for k, v in where["phases"].items())
    axes = ", ".join(f"{k} {v:.0%}" for k, v in where["axis_share"].items())
    bands = ", ".join(f"{k} {v:.0%}" for k, v in where["frequency_share"].items())
    return f"by phase {phases}; nodes {where['top_nodes']}; by axis {axes}; by frequency {bands}"


def _variant(objective: TrajectoryObjective, trajectories: Sequence[int], horizon: int | str) -> TrajectoryObjective:
    """A serial objective with ``objective``'s model and options on some of its trajectories at ``horizon``."""
    data = [objective.trajectories[k] for k in trajectories]
    return TrajectoryObjective(data, horizon=horizon, loss="squared", options=objective.options,
                               effects=objective.effects, actuators=objective.actuators, n_workers=0)


def _drift(objective: TrajectoryObjective, theta: np.ndarray, k: int, at: float) -> float:
    """Mean node distance [m] between a free rollout from the first sample and trajectory k at ``at`` s
    after its start (the last sample if shorter), at the nearest sample both have (the rollout runs on
    through dropped frames, the recording has none there); inf if the rollout diverges."""
    ds = objective.trajectories[k]
    try:
        pred = _variant(objective, [k], "rollout").predictions(theta)[0].transpose("time", "node", "axis").values
    except PhysicsError:   # a diverging simulation: the drift is unbounded
        return float("inf")
    t = np.asarray(ds["time"].values, float)
    observed = np.asarray(ds["nodes"].transpose("time", "node", "axis").values, float)
    both = np.flatnonzero(np.isfinite(observed).all(axis=(1, 2)) & np.isfinite(pred).all(axis=(1, 2)))
    if both.size == 0:
        return float("nan")
    i = int(both[np.argmin(np.abs(t[both] - t[0] - at))])
    return float(np.linalg.norm(pred[i] - observed[i], axis=1).mean())


def held_scores(objective: TrajectoryObjective, theta: np.ndarray, held: Sequence[int],
                drift_time: float) -> HeldScores:
    """One-step error, windowed error (``objective``'s horizon) and drift at ``drift_time`` [s] of the
    trajectories ``held`` (indices into ``objective.trajectories``) at θ (D,)."""
    one, windows, drift = {}, {}, {}
    for k in held:
        key = f"t{k}"
        one[key] = float(_variant(objective, [k], 1)(theta))
        windows[key] = float(_variant(objective, [k], objective.horizon)(theta))
        drift[key] = _drift(objective, theta, k, drift_time)
    return HeldScores(one, windows, drift)


def one_step_error(objective: TrajectoryObjective, theta: np.ndarray, trajectories: Sequence[int]) -> float:
    """Σ_k Σ_i ||x_{i+1} − f(x_i, u_i, θ)||² [m²] over ``trajectories`` (indices into
    ``objective.trajectories``) at θ (D,); inf when a step diverges."""
    try:
        return float(_variant(objective, trajectories, 1)(theta))
    except PhysicsError:
        return float("inf")


def _band_shares(residual: np.ndarray, interval: float) -> dict[str, float]:
    """Share of Σ|R(f)|² per band of FREQUENCY_BANDS, R the FFT over time of the one-step residual (T x m)."""
    r = np.nan_to_num(np.asarray(residual, float), nan=0.0)
    power = (np.abs(np.fft.rfft(r - r.mean(axis=0), axis=0)) ** 2).sum(axis=1)
    freq = np.fft.rfftfreq(len(r), d=interval)
    edges = [*FREQUENCY_BANDS, np.inf]
    total = float(power.sum())
    out = {}
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        label = f"{lo:g}-{hi:g} Hz" if np.isfinite(hi) else f">{lo:g} Hz"
        out[label] = float(power[(freq >= lo) & (freq < hi)].sum()) / total if total > 0 else float("nan")
    return out


def localize(objective: TrajectoryObjective, theta: np.ndarray, trajectories: Sequence[int]) -> dict[str, Any]:
    """Where the one-step residual of ``trajectories`` lives at θ: criticism.residuals' summary (shares
    by phase, top nodes, shares by axis) plus ``frequency_share``, the share of its power per band
    of FREQUENCY_BANDS (averaged over the trajectories)."""
    one = _variant(objective, trajectories, 1)
    preds = one.predictions(theta)
    summary = residual_summary(residual_dataset(one, theta, predictions=preds))
    shares = []
    for ds, pred in zip(one.trajectories, preds, strict=True):
        r = (np.asarray(ds["nodes"].values, float) - np.asarray(pred.values, float)).reshape(len(pred), 36)
        t = np.asarray(ds["time"].values, float)
        shares.append(_band_shares(r[1:], float(t[1] - t[0])))
    summary["frequency_share"] = {k: float(np.mean([s[k] for s in shares])) for k in shares[0]}
    return summary
