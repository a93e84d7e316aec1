"""The result of an identification run, saved to and loaded from one netCDF file (groups).

File layout (netCDF4 groups): ``/posterior`` (the DataArray P over the grid dims), ``/history``
(one row per evaluation, dims ``evaluation``, ``latent``, ``parameter``), ``/marginals`` (dim
``parameter``); root attributes hold the run's configuration as JSON and the best error.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from belief.errors import BeliefError
from belief.posterior import credible_region

__all__ = ["IdentificationResult", "history_dataset"]


def history_dataset(records: list[Any], *, latent_names: tuple[str, ...], space: Any) -> xr.Dataset:
    """Evaluation records -> Dataset with ``z`` (evaluation, latent), ``theta`` (evaluation, parameter),
    ``error`` [units of E], ``seconds`` [s], ``status``, ``message``, ``cell``, ``batch`` (evaluation)."""
    n, d, D = len(records), len(latent_names), space.dim
    z = np.array([r.z for r in records], dtype=float).reshape(n, d)
    th = np.array([r.theta for r in records], dtype=float).reshape(n, D)
    ds = xr.Dataset(
        {
            "z": (("evaluation", "latent"), z),
            "theta": (("evaluation", "parameter"), th),
            "error": ("evaluation", np.array([r.error for r in records], dtype=float)),
            "seconds": ("evaluation", np.array([r.seconds for r in records], dtype=float)),
            "status": ("evaluation", np.array([r.status for r in records], dtype=object).astype(str)),
            "message": ("evaluation", np.array([r.message for r in records], dtype=object).astype(str)),
            "cell": ("evaluation", np.array([r.cell for r in records], dtype=np.int64)),
            "batch": ("evaluation", np.array([r.batch for r in records], dtype=np.int64)),
        },
        coords={"evaluation": np.arange(n), "latent": list(latent_names), "parameter": list(space.names),
                "unit": ("parameter", list(space.units))},
    )
    ds["error"].attrs["long_name"] = "trajectory error E(theta)"
    ds["seconds"].attrs["units"] = "s"
    return ds


@dataclass
class IdentificationResult:
    """Output of :func:`belief.identify`.

    ``posterior``: DataArray P over the grid dims (>= 0, sums to 1); ``history``: Dataset of every
    evaluation in order (see :func:`history_dataset`); ``marginals``: Dataset over ``parameter``
    (mean, std, lower, upper, map, prior_mean, prior_std, identified); ``best_theta``: DataArray over
    ``parameter`` (θ of the smallest observed error); ``best_error``; ``config``: JSON-able options.
    """

    posterior: xr.DataArray | None
    history: xr.Dataset
    marginals: xr.Dataset | None
    best_theta: xr.DataArray
    best_error: float
    config: dict[str, Any] = field(default_factory=dict)

    @property
    def n_evaluations(self) -> int:
        return int(self.history.sizes["evaluation"])

    def credible_region(self, *, level: float = 0.9) -> xr.DataArray:
        """Boolean DataArray: the ``level`` highest-posterior-density cells of P."""
        if self.posterior is None:
            raise BeliefError("this result has no posterior (identify(..., posterior=None)).")
        return credible_region(self.posterior, level=level)

    def summary(self) -> str:
        """Plain-text table of the marginals (one row per parameter)."""
        m = self.marginals
        if m is None:
            return f"best error {self.best_error:.6g} after {self.n_evaluations} evaluations (no posterior)"
        lines = [f"{'parameter':<18}{'unit':<10}{'mean':>12}{'std':>12}{'lower':>12}{'upper':>12}"
                 f"{'prior_std':>12}  identified"]
        for i, name in enumerate(m["parameter"].values):
            lines.append(
                f"{str(name):<18}{str(m['unit'].values[i]):<10}{m['mean'].values[i]:>12.5g}{m['std'].values[i]:>12.5g}"
                f"{m['lower'].values[i]:>12.5g}{m['upper'].values[i]:>12.5g}{m['prior_std'].values[i]:>12.5g}"
                f"  {'yes' if bool(m['identified'].values[i]) else 'no'}"
            )
        lines.append(f"best error {self.best_error:.6g} after {self.n_evaluations} evaluations")
        return "\n".join(lines)

    def save(self, path: "str | os.PathLike[str]") -> None:
        """Write the result to a netCDF4 file with groups posterior, history, marginals."""
        path = os.fspath(path)
        root = xr.Dataset(attrs={"config": json.dumps(self.config), "best_error": float(self.best_error),
                                 "format": "tensegrid.identification/1"})
        root["best_theta"] = self.best_theta
        root.to_netcdf(path, mode="w", engine="netcdf4")
        if self.posterior is not None:
            post = self.posterior.to_dataset(name="P")
            post.attrs = dict(self.posterior.attrs)
            post.to_netcdf(path, mode="a", group="posterior", engine="netcdf4")
        self.history.to_netcdf(path, mode="a", group="history", engine="netcdf4")
        if self.marginals is not None:
            marg = self.marginals.copy()
            marg["identified"] = marg["identified"].astype(np.int8)
            marg.to_netcdf(path, mode="a", group="marginals", engine="netcdf4")

    @classmethod
    def load(cls, path: "str | os.PathLike[str]") -> "IdentificationResult":
        """Read a file written by :meth:`save`."""
        path = os.fspath(path)
        if not os.path.exists(path):
            raise BeliefError(f"no result file at {path!r}; write one with IdentificationResult.save(path).")
        with xr.open_dataset(path, engine="netcdf4") as root:
            root = root.load()
        if root.attrs.get("format") != "tensegrid.identification/1":
            raise BeliefError(f"{path!r} is not a tensegrid identification result (missing format attribute).")
        import netCDF4

        with netCDF4.Dataset(path) as nc:
            groups = set(nc.groups)
        P = marg = None
        if "posterior" in groups:
            with xr.open_dataset(path, group="posterior", engine="netcdf4") as post:
                post = post.load()
            P = post["P"]
            P.attrs = dict(post.attrs)
        with xr.open_dataset(path, group="history", engine="netcdf4") as hist:
            hist = hist.load()
        if "marginals" in groups:
            with xr.open_dataset(path, group="marginals", engine="netcdf4") as marg:
                marg = marg.load()
            marg["identified"] = marg["identified"].astype(bool)
        for name in ("status", "message"):
            hist[name] = hist[name].astype(str)
        return cls(posterior=P, history=hist, marginals=marg, best_theta=root["best_theta"],
                   best_error=float(root.attrs["best_error"]), config=json.loads(root.attrs["config"]))
