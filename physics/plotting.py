"""Pictures of trajectories (matplotlib, Agg backend): the robot at a few instants and the path
of its centre of mass. DART's own viewer cannot render off-screen from the pip wheel."""
from __future__ import annotations

import os
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from physics.geometry import CABLE_NODES, ROD_NODES  # noqa: E402

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d import Axes3D

__all__ = ["draw_robot", "plot_trajectory", "plot_observed_vs_predicted", "observed_vs_predicted_figure",
           "centre_of_mass", "rollout_errors"]


def _save(fig: Figure, path: str | os.PathLike[str], *, layout: bool = True) -> Path:
    """Lay out (unless the caller did), write (creating the folder) and close a figure; returns the path."""
    if layout:
        fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def draw_robot(ax: Axes3D, nodes: np.ndarray, *, color: str = "C0", alpha: float = 1.0,
               tension: np.ndarray | None = None) -> None:
    """Draw rods (thick) and cables (thin; red when taut above 1 N if ``tension`` is given) on a 3-D axis."""
    for a, b in CABLE_NODES:
        ax.plot(*nodes[[a, b]].T, color="0.6", lw=0.8, alpha=alpha)
    if tension is not None:
        for (a, b), t in zip(CABLE_NODES, tension, strict=True):
            if t > 1.0:
                ax.plot(*nodes[[a, b]].T, color="C3", lw=0.6, alpha=alpha * 0.8)
    for a, b in ROD_NODES:
        ax.plot(*nodes[[a, b]].T, color=color, lw=3.0, alpha=alpha, solid_capstyle="round")


def plot_trajectory(ds: xr.Dataset, path: str | os.PathLike[str], *, snapshots: int = 2,
                    title: str | None = None) -> Path:
    """Save a figure: robot snapshots over time (left) and centre-of-mass path and height (right)."""
    nodes = ds["nodes"].transpose("time", "node", "axis").values
    t = ds["time"].values
    com = np.nanmean(nodes, axis=1)
    fig = plt.figure(figsize=(11, 4.6))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    idx = np.linspace(0, len(t) - 1, snapshots).round().astype(int)
    colors = plt.cm.viridis(np.linspace(0.75, 0.1, snapshots))
    for k, i in enumerate(idx):
        last = k == snapshots - 1
        tension = ds["tension"].values[i] if ("tension" in ds and last) else None
        draw_robot(ax, nodes[i], color=colors[k], alpha=1.0 if last else 0.3, tension=tension)
    ax.plot(*com.T, color="k", lw=1.5, label="centre of mass")
    lo, hi = np.nanmin(nodes.reshape(-1, 3), axis=0), np.nanmax(nodes.reshape(-1, 3), axis=0)
    mid, span = 0.5 * (lo + hi), float(np.max(hi - lo)) * 0.55
    ax.set_xlim(mid[0] - span, mid[0] + span)
    ax.set_ylim(mid[1] - span, mid[1] + span)
    ax.set_zlim(0, 2 * span)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title("robot at t = " + ", ".join(f"{t[i]:.1f}" for i in idx) + " s (faint to solid);\n"
                 "taut cables red in the last", fontsize=9)
    ax2 = fig.add_subplot(2, 2, 2)
    ax2.plot(t, com[:, 0] - com[0, 0], label="x")
    ax2.plot(t, com[:, 1] - com[0, 1], label="y")
    ax2.set_ylabel("COM displacement [m]")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    ax3 = fig.add_subplot(2, 2, 4, sharex=ax2)
    ax3.plot(t, com[:, 2], color="C2")
    ax3.set_ylabel("COM height [m]")
    ax3.set_xlabel("time [s]")
    ax3.grid(alpha=0.3)
    fig.suptitle(title or "SUPERball T6 trajectory")
    return _save(fig, path)


def centre_of_mass(nodes: np.ndarray) -> np.ndarray:
    """Mean over nodes (``T x N x 3`` -> ``T x 3``) of the samples whose nodes are all finite, NaN for the
    others: a sample with a dropped marker is a gap, not a jump of the centre toward the markers left."""
    nodes = np.asarray(nodes, dtype=float)
    complete = np.isfinite(nodes).all(axis=(1, 2))
    out = np.full((nodes.shape[0], nodes.shape[2]), np.nan)
    out[complete] = nodes[complete].mean(axis=1)
    return out


def _node_error(observed: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """||x - x̂|| over all nodes per sample [m] (``T``), NaN where either has a missing node."""
    diff = np.asarray(predicted, dtype=float) - np.asarray(observed, dtype=float)
    complete = np.isfinite(diff).all(axis=(1, 2))
    out = np.full(diff.shape[0], np.nan)
    out[complete] = np.sqrt((diff[complete] ** 2).sum(axis=(1, 2)))
    return out


def rollout_errors(ds: xr.Dataset, predictions: dict[str, xr.DataArray]) -> dict[str, float]:
    """label -> RMS over the samples where observation and prediction are complete of ||x - x̂|| [m]
    (NaN when there is none)."""
    observed = ds["nodes"].transpose("time", "node", "axis").values
    out = {}
    for name, pred in predictions.items():
        err = _node_error(observed, pred.transpose("time", "node", "axis").values)
        err = err[np.isfinite(err)]
        out[name] = float(np.sqrt(np.mean(err ** 2))) if err.size else float("nan")
    return out


def observed_vs_predicted_figure(ds: xr.Dataset, predictions: dict[str, xr.DataArray], *, title: str | None = None,
                                 note: str = "") -> Figure:
    """The figure of :func:`plot_observed_vs_predicted` (not saved; close it with ``plt.close``)."""
    observed = ds["nodes"].transpose("time", "node", "axis").values
    t = ds["time"].values
    com = centre_of_mass(observed)
    centre = {name: centre_of_mass(pred.transpose("time", "node", "axis").values) for name, pred in predictions.items()}
    rms = rollout_errors(ds, predictions)
    fig, axes = plt.subplots(4, 1, figsize=(8, 8.5), sharex=True)
    styles = ["--", ":", "-."]
    for k, label in enumerate("xyz"):
        axes[k].plot(t, com[:, k], color="k", lw=2.0, label="observed")
        for j, name in enumerate(predictions):
            axes[k].plot(t, centre[name][:, k], styles[j % 3], lw=1.5, label=f"{name} (RMS {rms[name]:.3g} m)")
        axes[k].set_ylabel(f"COM {label} [m]")
        axes[k].grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    for j, (name, pred) in enumerate(predictions.items()):
        err = _node_error(observed, pred.transpose("time", "node", "axis").values)
        axes[3].semilogy(t, np.maximum(err, 1e-9), styles[j % 3], label=name)
    axes[3].set_ylabel("||x - x̂|| over nodes [m]")
    axes[3].set_xlabel("time [s]")
    axes[3].grid(alpha=0.3, which="both")
    fig.suptitle(title or "observed vs predicted")
    if note:
        wrapped = textwrap.fill(note, 105)
        lines = wrapped.count("\n") + 1
        fig.text(0.5, 1.0 - 0.45 / 8.5, wrapped, ha="center", va="top", fontsize=8.5, color="0.25")
        fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - (0.3 + 0.15 * lines) / 8.5))
    else:
        fig.tight_layout()
    return fig


def plot_observed_vs_predicted(ds: xr.Dataset, predictions: dict[str, xr.DataArray], path: str | os.PathLike[str], *,
                               title: str | None = None, note: str = "") -> Path:
    """Save a figure of the observed centre of mass (x, y, z) against predictions (label -> nodes
    DataArray (time, node, axis), e.g. from ``TrajectoryObjective(ds, horizon="rollout").predictions(θ)``),
    each labelled with its RMS node error, and the per-sample node error ||x_i - x̂_i|| [m] below;
    ``note`` is printed under the title (e.g. why one rollout drifts). Samples with a missing node are
    gaps (:func:`centre_of_mass`)."""
    return _save(observed_vs_predicted_figure(ds, predictions, title=title, note=note), path, layout=False)
