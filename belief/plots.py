"""Figures of an identification result (matplotlib, Agg backend: no display needed).

- :func:`plot_error_trace`: E of every evaluation and the running best vs the evaluation count,
  in the unit of E, with a preset's finishing Gauss-Newton step;
- :func:`plot_marginals`: per-parameter marginal of P in θ units (weighted histogram of the
  decoded cell centres), with the credible interval, the prior and an optional truth;
- :func:`plot_pairs`: the 2-D marginals of P of the two or three parameters most correlated under P;
- :func:`plot_posterior_2d`: P as an image for a 2-D grid (e.g. the push toy).

Axes of small or large parameters (motor_radius in m, motor_friction in N*m*s) show the values
scaled by a power of ten named in the label (:func:`display_scale`), never a floating offset.
The plot functions save the figure, close it and return it, so its axes can be inspected.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from embeddings.base import Decoder  # noqa: E402
from embeddings.identity import Identity  # noqa: E402
from physics.parameters import ParameterSpace  # noqa: E402

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from belief.belief import Belief
    from belief.result import IdentificationResult

__all__ = ["plot_error_trace", "plot_marginals", "plot_pairs", "plot_posterior_2d", "display_scale", "scaled_label",
           "error_unit", "correlation", "most_correlated", "rollout_note"]

#: colour of the credible interval's shading and edges
_INTERVAL = "tab:orange"


def display_scale(lower: float, upper: float) -> tuple[float, int]:
    """(factor, exponent) so that values in [lower, upper] times factor = 10**-exponent read as plain
    numbers: exponent 0 when the largest magnitude lies in [0.1, 1e4), else a multiple of 3."""
    top = max(abs(float(lower)), abs(float(upper)))
    if not np.isfinite(top) or top == 0 or 0.1 <= top < 1e4:
        return 1.0, 0
    exponent = 3 * int(np.floor(np.log10(top) / 3))
    return 10.0 ** -exponent, exponent


def scaled_label(name: str, unit: str, exponent: int) -> str:
    """``name [unit]``, or ``name [10^exponent unit]`` (mathtext) for scaled values."""
    scale = "" if exponent == 0 else f"$10^{{{exponent}}}$ "
    return f"{name} [{scale}{unit}]"


def _plain_ticks(ax: Axes, *, nbins: int = 4) -> None:
    """At most ``nbins`` x ticks, no offset and no scientific multiplier on either axis."""
    ax.xaxis.set_major_locator(MaxNLocator(nbins=nbins))
    ax.ticklabel_format(axis="both", style="plain", useOffset=False)


def error_unit(config: Mapping[str, Any]) -> tuple[str, str]:
    """(unit, meaning) of the error E of a result's ``config`` (its objective's kind and loss)."""
    objective = config.get("objective") or {}
    kind, loss = objective.get("kind"), objective.get("loss", "squared")
    if kind == "push":
        return "m²", "sum of squared displacement residuals"
    if isinstance(kind, str) and "TrajectoryObjective" in kind:
        horizon = str(objective.get("horizon", "1"))
        what = "one-step" if horizon == "1" else f"{horizon}-sample window"
        if loss == "norm":
            return "m", f"sum of the {what} prediction's node-position residual norms"
        return "m²", f"sum of the {what} prediction's squared node-position residuals"
    return "", "units of the objective"


def plot_error_trace(result: IdentificationResult, path: str | os.PathLike[str], *, label: str | None = None) -> Figure:
    """Scatter E per evaluation (failed ones marked at the top), the running minimum and, when the result
    has one (``config["local_step"]``, belief.presets), the finishing Gauss-Newton step after the
    evaluations; E in its unit (:func:`error_unit`), log y axis if E > 0."""
    h = result.history
    err = h["error"].values
    n = np.arange(1, err.size + 1)
    ok = h["status"].values == "ok"
    run = np.fmin.accumulate(np.where(ok, err, np.inf))
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(n[ok], err[ok], ".", color="0.6", label="E(θ) of each evaluation")
    ax.step(n, run, where="post", color="C0", label=label or "best so far")
    if np.any(~ok):
        top = np.nanmax(err[ok]) if np.any(ok) else 1.0
        ax.plot(n[~ok], np.full((~ok).sum(), top), "x", color="C3", label="failed")
    step = result.config.get("local_step")
    xlabel = "evaluations"
    if step:
        end = err.size + int((result.config.get("evaluations") or {}).get("after_search", step["evaluations"]))
        ax.plot([err.size, end], [step["start_error"], step["error"]], "-", color="C2", lw=1.5)
        ax.plot([end], [step["error"]], "*", color="C2", ms=11,
                label=f"Gauss-Newton step ({step['evaluations']} evaluations of E): "
                      f"E {step['start_error']:.3g} → {step['error']:.3g}")
        xlabel = "evaluations of E: the search's, then the Gauss-Newton step's"
    if np.all(err[ok] > 0):
        ax.set_yscale("log")
    unit, meaning = error_unit(result.config)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(f"error E [{unit}]" if unit else "error E")
    ax.set_title(f"E: {meaning}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return fig


def _edges(values: np.ndarray, lower: float, upper: float, bins: int, *, most: int = 100) -> np.ndarray:
    """Histogram edges: one bin per distinct decoded value when there are 2 to ``most`` of them (grid-aligned,
    no aliasing), else ``bins`` equal bins over [lower, upper]."""
    u = np.unique(values)
    if 2 <= u.size <= most:
        mid = 0.5 * (u[1:] + u[:-1])
        return np.concatenate([[u[0] - (mid[0] - u[0])], mid, [u[-1] + (u[-1] - mid[-1])]])
    return np.linspace(lower, upper, bins + 1)


def _marginal_panel(ax: Axes, j: int, p: np.ndarray, theta: np.ndarray, space: ParameterSpace,
                    marginals: xr.Dataset | None, truth: np.ndarray | None, bins: int) -> None:
    """Parameter j's panel of :func:`plot_marginals`, in scaled units (:func:`display_scale`)."""
    factor, exponent = display_scale(space.lower[j], space.upper[j])
    x = theta[:, j] * factor
    edges = (_edges(theta[:, j], space.lower[j], space.upper[j], bins) * factor).tolist()
    if marginals is not None:
        lo, hi = float(marginals["lower"][j]) * factor, float(marginals["upper"][j]) * factor
        level = float(marginals.attrs.get("level", 0.9))
        ax.axvspan(lo, hi, color=_INTERVAL, alpha=0.25, lw=0, zorder=0, label=f"{level:.0%} credible interval")
        for edge in (lo, hi):
            ax.axvline(edge, color=_INTERVAL, lw=1.2, ls="--", zorder=5)
    ax.hist(x, bins=edges, weights=p, color="C0", alpha=0.8, zorder=2, label="posterior P")
    ax.hist(x, bins=edges, weights=np.full(p.size, 1.0 / p.size), histtype="step", color="0.25", lw=1.2, zorder=3,
            label="prior (uniform over the cells)")
    if truth is not None:
        ax.axvline(float(truth[j]) * factor, color="C3", lw=1.5, zorder=4, label="truth")
    verdict = "" if marginals is None or "verdict" not in marginals else f"\n{marginals['verdict'].values[j]}"
    ax.set_title(f"{space.names[j]}{verdict}", fontsize=9)
    ax.set_xlabel(scaled_label(space.names[j], space.units[j], exponent), fontsize=8)
    _plain_ticks(ax)
    ax.tick_params(labelsize=7)


def plot_marginals(
    P: xr.DataArray, theta: np.ndarray, space: ParameterSpace, path: str | os.PathLike[str], *,
    marginals: xr.Dataset | None = None, truth: np.ndarray | Sequence[float] | None = None, bins: int = 30,
) -> Figure:
    """One panel per parameter: histogram of θ_j weighted by P (``theta``: decoded cells ``n x D``) vs the
    prior, the credible interval shaded and the verdict under the title when ``marginals`` has them;
    one legend under the panels."""
    p = np.asarray(P.values, dtype=float).ravel()
    tr = None if truth is None else np.asarray(truth, dtype=float)
    D = space.dim
    ncol = min(D, 5)
    nrow = int(np.ceil(D / ncol))
    height = 2.7 * nrow + 0.5
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.1 * ncol + 0.4, height), squeeze=False)
    for j in range(D):
        ax = axes[j // ncol][j % ncol]
        _marginal_panel(ax, j, p, theta, space, marginals, tr, bins)
        if j % ncol == 0:
            ax.set_ylabel("probability per bin", fontsize=8)
    for k in range(D, nrow * ncol):
        axes[k // ncol][k % ncol].axis("off")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0.0, 0.4 / height, 1.0, 1.0))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return fig


def correlation(theta: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Correlation matrix ``D x D`` of θ under the cell weights ``p`` (0 where a parameter does not vary)."""
    w = np.asarray(p, dtype=float) / float(np.sum(p))
    centred = np.asarray(theta, dtype=float) - w @ theta
    cov = centred.T @ (w[:, None] * centred)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    scale = np.outer(std, std)
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = np.where(scale > 0, cov / np.where(scale > 0, scale, 1.0), 0.0)
    np.fill_diagonal(rho, 1.0)
    return np.asarray(np.clip(rho, -1.0, 1.0))


def most_correlated(rho: np.ndarray, k: int = 3) -> list[int]:
    """Indices of the ``k`` parameters most correlated under P: the pair with the largest |ρ|, then each
    time the parameter with the largest |ρ| to one already chosen (``k`` capped at D)."""
    r = np.abs(np.asarray(rho, dtype=float))
    np.fill_diagonal(r, -1.0)
    i, j = np.unravel_index(int(np.argmax(r)), r.shape)
    chosen = [int(i), int(j)]
    while len(chosen) < min(k, r.shape[0]):
        rest = [m for m in range(r.shape[0]) if m not in chosen]
        chosen.append(max(rest, key=lambda m: float(r[chosen, m].max())))
    return chosen


def _pair_panel(ax: Axes, x: np.ndarray, y: np.ndarray, p: np.ndarray, ex: np.ndarray, ey: np.ndarray,
                rho: float) -> None:
    """The 2-D marginal of P over (x, y) as an image, with ρ in the corner."""
    H, _, _ = np.histogram2d(x, y, bins=[ex, ey], weights=p)
    ax.pcolormesh(ex, ey, H.T, cmap="Blues", shading="flat")
    ax.text(0.03, 0.95, f"ρ = {rho:+.2f}", transform=ax.transAxes, va="top", fontsize=8,
            bbox={"facecolor": "white", "alpha": 0.8, "lw": 0})


def plot_pairs(belief: Belief, path: str | os.PathLike[str], *, k: int = 3,
               truth: np.ndarray | Sequence[float] | None = None, bins: int = 15) -> Figure | None:
    """Corner plot of the ``k`` parameters most correlated under P (:func:`most_correlated`): marginals of P
    on the diagonal, 2-D marginals below it with their correlation ρ, the truth when given. Returns None
    (and writes nothing) for a space of fewer than 2 parameters."""
    if belief.space.dim < 2:
        return None
    space, p, theta = belief.space, belief.p, belief.theta
    rho = correlation(theta, p)
    idx = most_correlated(rho, k)
    scaled = [display_scale(space.lower[j], space.upper[j]) for j in idx]
    vals = [theta[:, j] * f for j, (f, _) in zip(idx, scaled, strict=True)]
    edges = [_edges(theta[:, j], space.lower[j], space.upper[j], bins, most=30) * f
             for j, (f, _) in zip(idx, scaled, strict=True)]
    labels = [scaled_label(space.names[j], space.units[j], e) for j, (_, e) in zip(idx, scaled, strict=True)]
    tr = None if truth is None else [float(truth[j]) * f for j, (f, _) in zip(idx, scaled, strict=True)]
    n = len(idx)
    fig, axes = plt.subplots(n, n, figsize=(2.9 * n, 2.7 * n), squeeze=False)
    for r in range(n):
        for c in range(n):
            ax = axes[r][c]
            if c > r:
                ax.axis("off")
                continue
            if c == r:
                ax.hist(vals[c], bins=edges[c], weights=p, color="C0", alpha=0.8)
                ax.set_ylabel("probability per bin" if c == 0 else "", fontsize=8)
            else:
                _pair_panel(ax, vals[c], vals[r], p, edges[c], edges[r], float(rho[idx[r], idx[c]]))
                ax.set_ylabel(labels[r] if c == 0 else "", fontsize=8)
                if tr is not None:
                    ax.plot([tr[c]], [tr[r]], "*", color="C3", ms=10, label="truth")
            if tr is not None and c == r:
                ax.axvline(tr[c], color="C3", lw=1.5)
            ax.set_xlabel(labels[c] if r == n - 1 else "", fontsize=8)
            _plain_ticks(ax, nbins=4)
            ax.tick_params(labelsize=7)
    fig.suptitle(f"the {n} parameters most correlated under P (2-D marginals of P; red: truth)"
                 if tr is not None else f"the {n} parameters most correlated under P (2-D marginals of P)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return fig


def rollout_note(errors: Mapping[str, float]) -> str:
    """Why the best θ's open-loop rollout can be worse than the nominal θ's, when it is (``errors``: label ->
    RMS node error [m] of the rollouts, physics.plotting.rollout_errors), else ""."""
    best, nominal = errors.get("best", np.nan), errors.get("nominal", np.nan)
    if not (np.isfinite(best) and np.isfinite(nominal) and best > nominal):
        return ""
    return (f"The best θ drifts further than the nominal θ here (RMS node error {best:.3g} m vs {nominal:.3g} m): "
            "it minimises E, the error of predictions restarted from each observed state (one step or a short "
            "window), not the drift of a free rollout, which compounds small errors over the whole trajectory.")


def plot_posterior_2d(
    P: xr.DataArray, path: str | os.PathLike[str], *, decoder: Decoder | None = None,
    evaluated: np.ndarray | None = None, truth: np.ndarray | Sequence[float] | None = None,
    ridge: Callable[[np.ndarray], np.ndarray] | None = None, title: str = "posterior P",
) -> None:
    """Image of a 2-D P (dims z0, z1); axes in θ units when ``decoder`` maps z linearly (Identity).

    ``evaluated``: latent points ``n x 2`` to overlay; ``truth``: θ (2); ``ridge``: callable
    θ (n x 2) -> value whose level set through ``truth`` is drawn (e.g. m^2 mu for the push toy).
    """
    if P.ndim != 2:
        raise ValueError(f"plot_posterior_2d needs a 2-D P, got dims {P.dims}.")
    z0, z1 = P[P.dims[0]].values, P[P.dims[1]].values
    x, y = z0, z1
    xl, yl = str(P.dims[0]), str(P.dims[1])
    to_xy = lambda z: z  # noqa: E731
    if isinstance(decoder, Identity):
        lo, hi = decoder.space.lower, decoder.space.upper
        x, y = lo[0] + z0 * (hi[0] - lo[0]), lo[1] + z1 * (hi[1] - lo[1])
        xl = f"{decoder.space.names[0]} [{decoder.space.units[0]}]"
        yl = f"{decoder.space.names[1]} [{decoder.space.units[1]}]"
        to_xy = lambda z: lo + np.asarray(z) * (hi - lo)  # noqa: E731
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    im = ax.pcolormesh(x, y, P.values.T, shading="nearest", cmap="viridis")
    fig.colorbar(im, ax=ax, label="P")
    if evaluated is not None and len(evaluated):
        ev = to_xy(np.asarray(evaluated))
        ax.plot(ev[:, 0], ev[:, 1], "w.", ms=4, label="evaluations")
    if truth is not None:
        ax.plot([truth[0]], [truth[1]], "r*", ms=12, label="truth")
        if ridge is not None:
            X, Y = np.meshgrid(np.linspace(x.min(), x.max(), 200), np.linspace(y.min(), y.max(), 200))
            R = ridge(np.stack([X.ravel(), Y.ravel()], axis=1)).reshape(X.shape)
            ax.contour(X, Y, R, levels=[float(ridge(np.asarray(truth)[None])[0])], colors="r", linewidths=1)
    ax.set_xlabel(xl)
    ax.set_ylabel(yl)
    ax.set_title(title)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
