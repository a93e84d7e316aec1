"""Figures of an identification result (matplotlib, Agg backend: no display needed).

- :func:`plot_error_trace`: E of every evaluation and the running best vs the evaluation count;
- :func:`plot_marginals`: per-parameter marginal of P in θ units (weighted histogram of the
  decoded cell centres), with the 90 % interval, the prior and an optional truth;
- :func:`plot_posterior_2d`: P as an image for a 2-D grid (e.g. the push toy).
"""
from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from embeddings.base import Decoder  # noqa: E402
from embeddings.identity import Identity  # noqa: E402
from physics.parameters import ParameterSpace  # noqa: E402

if TYPE_CHECKING:
    from belief.result import IdentificationResult

__all__ = ["plot_error_trace", "plot_marginals", "plot_posterior_2d"]


def plot_error_trace(result: IdentificationResult, path: str | os.PathLike[str], *, label: str | None = None) -> None:
    """Scatter E per evaluation (failed ones marked at the top) and the running minimum; log y axis if E > 0."""
    h = result.history
    err = h["error"].values
    n = np.arange(1, err.size + 1)
    ok = h["status"].values == "ok"
    run = np.fmin.accumulate(np.where(ok, err, np.inf))
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(n[ok], err[ok], ".", color="0.6", label="E(θ) of each evaluation")
    ax.step(n, run, where="post", color="C0", label=label or "best so far")
    if np.any(~ok):
        top = np.nanmax(err[ok]) if np.any(ok) else 1.0
        ax.plot(n[~ok], np.full((~ok).sum(), top), "x", color="C3", label="failed")
    if np.all(err[ok] > 0):
        ax.set_yscale("log")
    ax.set_xlabel("evaluations")
    ax.set_ylabel("error E")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_marginals(
    P: xr.DataArray, theta: np.ndarray, space: ParameterSpace, path: str | os.PathLike[str], *,
    marginals: xr.Dataset | None = None, truth: np.ndarray | Sequence[float] | None = None, bins: int = 30,
) -> None:
    """One panel per parameter: histogram of θ_j weighted by P (``theta``: decoded cells ``n x D``) vs the
    prior, the credible interval shaded and the verdict under the title when ``marginals`` has them."""
    p = np.asarray(P.values, dtype=float).ravel()
    D = space.dim
    ncol = min(D, 5)
    nrow = int(np.ceil(D / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.0 * ncol, 2.4 * nrow), squeeze=False)
    for j in range(D):
        ax = axes[j // ncol][j % ncol]
        u = np.unique(theta[:, j])
        if 2 <= u.size <= 100:  # grid-aligned bins: one per distinct decoded value (no aliasing)
            mid = 0.5 * (u[1:] + u[:-1])
            edges = np.concatenate([[u[0] - (mid[0] - u[0])], mid, [u[-1] + (u[-1] - mid[-1])]])
        else:
            edges = np.linspace(space.lower[j], space.upper[j], bins + 1)
        ax.hist(theta[:, j], bins=edges, weights=np.full(p.size, 1.0 / p.size), histtype="step", color="0.5",
                label="prior")
        ax.hist(theta[:, j], bins=edges, weights=p, color="C0", alpha=0.7, label="posterior")
        if marginals is not None:
            ax.axvspan(float(marginals["lower"][j]), float(marginals["upper"][j]), color="C0", alpha=0.12)
        if truth is not None:
            ax.axvline(truth[j], color="C3", label="truth")
        verdict = "" if marginals is None or "verdict" not in marginals else f"\n{marginals['verdict'].values[j]}"
        ax.set_title(f"{space.names[j]} [{space.units[j]}]{verdict}", fontsize=9)
        ax.tick_params(labelsize=7)
    for k in range(D, nrow * ncol):
        axes[k // ncol][k % ncol].axis("off")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


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
