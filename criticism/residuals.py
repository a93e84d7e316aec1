"""Where the model misses: residuals r_i = x_i - x̂_i by node, axis and time, labelled by phase.

For the trajectories of an objective with ``predictions(θ)``
(:class:`physics.effect_objective.EffectObjective`, e.g. physics.TrajectoryObjective) the
residual of sample i is the observed node positions minus the predicted ones (12 x 3) [m].
Each sample gets one phase, from the data alone (no θ):

- ``contact``: a node crosses the contact height h_c within ``contact_window`` samples (a cap
  lands or lifts off); h_c = median height of the three lowest nodes at the first finite sample
  + ``contact_margin``;
- ``actuating``: a command changed within the last ``settle_time`` seconds (motors still move); a
  sample without commands (a dropped frame) holds the last one sent, so a change across it counts;
- ``rest``: neither.

Samples whose residual is not finite (NaN observations, nothing predicted) are left out of every
figure and counted (``skipped``), never imputed.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from physics.effect_objective import EffectObjective
from physics.predictor import held_commands

__all__ = ["PHASES", "PhaseRule", "phases", "residual_dataset", "residual_summary"]

PHASES = ("rest", "actuating", "contact")


@dataclass(frozen=True)
class PhaseRule:
    """Thresholds of the phase labels: settle_time [s], contact_margin [m], contact_window [samples]."""

    settle_time: float = 0.3
    contact_margin: float = 0.01
    contact_window: int = 2


def phases(ds: xr.Dataset, rule: PhaseRule = PhaseRule()) -> np.ndarray:
    """Phase label (T,) of every sample of one trajectory (module docstring), as strings of PHASES."""
    nodes = np.asarray(ds["nodes"].transpose("time", "node", "axis").values, float)
    controls = held_commands(np.asarray(ds["controls"].transpose("time", "cable").values, float))
    times = np.asarray(ds["time"].values, float)
    T = len(times)
    label = np.full(T, "rest", dtype=object)
    changed = np.zeros(T, bool)
    changed[1:] = (np.nan_to_num(np.abs(np.diff(controls, axis=0)), nan=0.0) > 1e-9).any(axis=1)
    change_times = times[changed]
    for i, t in enumerate(times):
        if np.any((change_times <= t + 1e-12) & (change_times > t - rule.settle_time)):
            label[i] = "actuating"
    first = int(np.argmax(np.isfinite(nodes).all(axis=(1, 2))))
    h_c = float(np.median(np.sort(nodes[first, :, 2])[:3])) + rule.contact_margin
    low = nodes[:, :, 2] < h_c
    crossing = np.zeros(T, bool)
    finite = np.isfinite(nodes[:, :, 2]).all(axis=1)
    crossing[1:] = (low[1:] != low[:-1]).any(axis=1) & finite[1:] & finite[:-1]
    for j in np.flatnonzero(crossing):
        label[max(0, j - rule.contact_window):j + rule.contact_window + 1] = "contact"
    return label.astype(str)


def residual_dataset(objective: EffectObjective, theta: np.ndarray, rule: PhaseRule = PhaseRule(),
                     predictions: list[xr.DataArray] | None = None) -> xr.Dataset:
    """Residuals of every trajectory of ``objective`` at θ, stacked along ``sample``.

    Variables: ``residual`` (sample, node, axis) [m], ``norm`` (sample) = ||r_i||_2, ``phase``
    (sample); coordinates ``trajectory`` and ``time`` (sample). Only finite samples are kept;
    ``attrs["skipped"]`` counts the others per trajectory (a list). ``predictions``: the objective's
    predictions at θ when already computed (one simulation fewer)."""
    preds = predictions if predictions is not None else objective.predictions(theta)
    blocks, skipped = [], []
    for k, (ds, pred) in enumerate(zip(objective.trajectories, preds, strict=True)):
        r = np.asarray(ds["nodes"].transpose("time", "node", "axis").values, float) - np.asarray(pred.values, float)
        keep = np.isfinite(r).all(axis=(1, 2))
        compared = np.isfinite(np.asarray(pred.values)).all(axis=(1, 2))
        skipped.append(int((compared & ~keep).sum() + (~np.isfinite(ds["nodes"].values).all(axis=(1, 2))).sum()))
        label = phases(ds, rule)
        blocks.append(xr.Dataset(
            {"residual": (("sample", "node", "axis"), r[keep], {"units": "m"}),
             "norm": (("sample",), np.sqrt((r[keep] ** 2).sum(axis=(1, 2))), {"units": "m"}),
             "phase": (("sample",), label[keep])},
            coords={"trajectory": ("sample", np.full(int(keep.sum()), k)),
                    "time": ("sample", np.asarray(ds["time"].values)[keep]),
                    "node": np.arange(12), "axis": ["x", "y", "z"]}))
    out = xr.concat(blocks, dim="sample")
    out.attrs["skipped"] = skipped
    return out


def residual_summary(res: xr.Dataset) -> dict[str, Any]:
    """Where the residual concentrates: RMS ||r|| [m] and share of Σ||r||² per phase, the three
    nodes and the axis with the largest share, and the NaN samples skipped."""
    sq = (res["residual"] ** 2)
    total = float(sq.sum())
    by_phase = {}
    for name in PHASES:
        mask = res["phase"] == name
        n = int(mask.sum())
        by_phase[name] = {"samples": n, "rms": float(np.sqrt((res["norm"][mask] ** 2).mean())) if n else float("nan"),
                          "share": float(sq.where(mask).sum()) / total if total > 0 else float("nan")}
    node_share = (sq.sum(("sample", "axis")) / total).values if total > 0 else np.zeros(12)
    axis_share = (sq.sum(("sample", "node")) / total).values if total > 0 else np.zeros(3)
    return {"phases": by_phase, "top_nodes": [int(i) for i in np.argsort(-node_share)[:3]],
            "node_share": node_share.tolist(), "axis_share": dict(zip("xyz", axis_share.tolist(), strict=True)),
            "skipped": list(res.attrs.get("skipped", [])), "samples": int(res.sizes["sample"])}
