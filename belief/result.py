"""The result of an identification run, saved to and loaded from one netCDF file (groups).

File layout (netCDF4 groups): ``/belief`` (the :class:`~belief.belief.Belief`: P, decoded θ,
verdicts, decoder and grid configurations), ``/history`` (one row per evaluation, dims
``evaluation``, ``latent``, ``parameter``, ``segment``); root attributes hold the run's
configuration as JSON and the best error.
"""
from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from belief.belief import Belief
from belief.bounds import AtBound
from belief.errors import BeliefError
from belief.identifiability import Identifiability
from belief.journal import Record
from belief.posterior import credible_region
from belief.scale import Scale
from physics.parameters import ParameterSpace

__all__ = ["IdentificationResult", "history_dataset", "noise_text", "floor_set", "FORMAT"]

FORMAT = "tensegrid.identification/2"


def noise_text(attrs: dict[str, Any]) -> str:
    """One line on what set the likelihood's σ² (belief.noise, belief.scale), from a Belief's attrs; "" without one.

    Under the "ess" rule σ² = max(E_min / K_eff, δ E_min / 2): the line names the larger term, so a
    reader sees whether the residuals' own count or the discrepancy δ (the model-error prior δ_0,
    or the segments' disagreement δ_seg) set the posterior's width."""
    sigma2, rule, info = attrs.get("noise_var"), attrs.get("noise_rule"), attrs.get("noise") or {}
    if sigma2 is None or not rule:
        return ""
    if rule == "calibrated" and "blocks_var" in info:
        return Scale(**info).text()
    if rule != "ess" or "discrepancy" not in info:
        return f"likelihood σ² = {sigma2:.4g} ({rule})"
    delta, seg = float(info["discrepancy"]), float(info["segment_discrepancy"])
    source = "the segments' disagreement" if seg >= delta else "the model-error floor δ_0"
    why = (f"set by the discrepancy δ = {delta:.3g} ({source}): an error {delta:.0%} above the best costs one nat"
           if floor_set(attrs) else f"set by the residuals: {info['n_effective']:.4g} effective of "
           f"{info['n_observations']} (δ = {delta:.3g} sets less)")
    return f"likelihood σ² = {sigma2:.4g}, {why}"


def floor_set(attrs: dict[str, Any]) -> bool:
    """Whether a Belief's σ² (its attrs) was set by the model-error floor δ E_min / 2 (belief.noise's
    "ess" rule, belief.scale's "calibrated"): such a σ² grows with E, and so with more data."""
    sigma2, rule, info = attrs.get("noise_var"), attrs.get("noise_rule"), attrs.get("noise") or {}
    if sigma2 is None:
        return False
    if rule == "calibrated" and "blocks_var" in info:
        return Scale(**info).floor_set
    if rule != "ess" or "discrepancy" not in info:
        return False
    return 0.5 * float(info["discrepancy"]) * float(attrs["best_error"]) >= float(sigma2) * (1.0 - 1e-9)


def history_dataset(records: Sequence[Record], *, latent_names: tuple[str, ...], space: ParameterSpace,
                    segments: tuple[str, ...] = ("all",)) -> xr.Dataset:
    """Evaluation records -> Dataset with ``z`` (evaluation, latent), ``theta`` (evaluation, parameter),
    ``parts`` (evaluation, segment) the segment errors (NaN unless ok), ``error`` [units of E],
    ``seconds`` [s], ``status``, ``message``, ``cell``, ``batch`` (evaluation)."""
    n, d, D, S = len(records), len(latent_names), space.dim, len(segments)
    parts = np.full((n, S), np.nan)
    for k, r in enumerate(records):
        if len(r.parts) == S:
            parts[k] = r.parts
    z = np.array([r.z for r in records], dtype=float).reshape(n, d)
    th = np.array([r.theta for r in records], dtype=float).reshape(n, D)
    ds = xr.Dataset(
        {
            "z": (("evaluation", "latent"), z),
            "theta": (("evaluation", "parameter"), th),
            "parts": (("evaluation", "segment"), parts),
            "error": ("evaluation", np.array([r.error for r in records], dtype=float)),
            "seconds": ("evaluation", np.array([r.seconds for r in records], dtype=float)),
            "status": ("evaluation", np.array([r.status for r in records], dtype=object).astype(str)),
            "message": ("evaluation", np.array([r.message for r in records], dtype=object).astype(str)),
            "cell": ("evaluation", np.array([r.cell for r in records], dtype=np.int64)),
            "batch": ("evaluation", np.array([r.batch for r in records], dtype=np.int64)),
        },
        coords={"evaluation": np.arange(n), "latent": list(latent_names), "parameter": list(space.names),
                "segment": list(segments),
                "unit": ("parameter", list(space.units))},
    )
    ds["error"].attrs["long_name"] = "trajectory error E(theta)"
    ds["seconds"].attrs["units"] = "s"
    return ds


@dataclass
class IdentificationResult:
    """Output of :func:`belief.identify`.

    ``belief``: the :class:`~belief.belief.Belief` (P, decoded θ, verdicts; None with
    ``posterior=None``); ``history``: Dataset of every evaluation in order (see
    :func:`history_dataset`); ``best_theta``: DataArray over ``parameter`` (θ of the smallest
    observed error); ``best_error``; ``config``: JSON-able options. ``posterior`` (P),
    ``marginals`` (per parameter: mean, std, lower, upper, map, prior_mean, prior_std, verdict,
    reason, identified, at_bound) and ``at_bounds`` (parameters pinned at a bound, belief.bounds)
    are read from the belief.
    """

    belief: Belief | None
    history: xr.Dataset
    best_theta: xr.DataArray
    best_error: float
    config: dict[str, Any] = field(default_factory=dict)

    @property
    def posterior(self) -> xr.DataArray | None:
        """P over the grid dims (>= 0, sums to 1), or None."""
        return None if self.belief is None else self.belief.P

    @property
    def marginals(self) -> xr.Dataset | None:
        """Per-parameter summaries of P with verdicts (Belief.marginals), or None."""
        return None if self.belief is None else self.belief.marginals()

    @property
    def at_bounds(self) -> tuple[AtBound, ...]:
        """Parameters pinned at a bound of the box after fitting (Belief.at_bounds; empty without a belief)."""
        return () if self.belief is None else self.belief.at_bounds

    @property
    def identifiability(self) -> Identifiability | None:
        """What the data pin, named (belief.identifiability), when the run ended with the local stage."""
        record = None if self.belief is None else self.belief.attrs.get("identifiability")
        return None if record is None else Identifiability.from_dict(record)

    @property
    def n_evaluations(self) -> int:
        return int(self.history.sizes["evaluation"])

    def records(self) -> list[Record]:
        """The evaluations of :attr:`history` as journal Records, in its order (segment errors kept for
        successful ones)."""
        h = self.history
        parts = np.asarray(h["parts"].values, dtype=float)
        return [Record(int(h["batch"].values[k]), int(h["cell"].values[k]), tuple(float(v) for v in h["z"].values[k]),
                       tuple(float(v) for v in h["theta"].values[k]), float(h["error"].values[k]),
                       float(h["seconds"].values[k]), str(h["status"].values[k]), str(h["message"].values[k]),
                       tuple(float(v) for v in parts[k]) if str(h["status"].values[k]) == "ok" else ())
                for k in range(self.n_evaluations)]

    def credible_region(self, *, level: float = 0.9) -> xr.DataArray:
        """Boolean DataArray: the ``level`` highest-posterior-density cells of P."""
        if self.belief is None:
            raise BeliefError("this result has no posterior (identify(..., posterior=None)).")
        return credible_region(self.belief.P, level=level)

    def evaluations_text(self) -> str:
        """How many evaluations of E the run made and of what budget: the search's and those after it
        (σ² residuals, Gauss-Newton steps: belief.search), when the config records them."""
        made = self.config.get("evaluations") or {}
        total, after = int(made.get("total", self.n_evaluations)), int(made.get("after_search", 0))
        budget = self.config.get("budget")
        text = f"{total} evaluations of E"
        if budget is not None:
            text += f" (budget {budget}" + (", which counts the search's)" if total > int(budget) else ")")
        if after:
            text += (f": {int(made.get('search', self.n_evaluations))} by the search and {after} after it (σ²'s "
                     "residuals, the Gauss-Newton step)")
        return text

    def summary(self, truth: np.ndarray | None = None) -> str:
        """Plain-text table of the marginals and verdicts (``truth``: a column of the true θ)."""
        tail = f"best error {self.best_error:.6g} after {self.evaluations_text()}"
        step = self.config.get("local_step")
        if step:                                        # a preset's finishing step (belief.presets)
            tail += (f"; the finishing Gauss-Newton step took E {step['start_error']:.6g} -> {step['error']:.6g}"
                     + (", its point is the best θ" if step["improved"] else ", no lower; the best θ is kept"))
        if self.belief is None:
            return tail + " (no posterior)"
        warn = self.belief.attrs.get("budget_warning")
        local = self.belief.attrs.get("local_fit") or {}
        stage = self.config.get("local_stage")
        if stage:
            tail += (f"\nlocal stage: Gauss-Newton fits from the {len(local.get('starts', []))} best evaluations "
                     f"({stage['fit_evaluations']} evaluations of E) end at E {local['error']:.6g}; then Algorithm 1 "
                     f"on a grid over the {stage['directions']} directions the data pin most ({stage['evaluations']} "
                     "evaluations of E); both outside the budget")
        elif "error" in local:
            tail += (f"\nlocal fit over all parameters: one Gauss-Newton step from "
                     f"the best evaluation gives E {local['error']:.6g} ({local['evaluations']} evaluations of E)")
        noise = noise_text(self.belief.attrs)
        tail += f"\n{noise}" if noise else ""
        pin = self.identifiability
        tail += ("\n" + "\n".join(pin.lines())) if pin is not None else ""
        trust = self.belief.attrs.get("trust")          # why P cannot be trusted (belief.verdicts.trust_note)
        tail += f"\nwarning: {trust}" if trust else ""
        best = np.asarray(self.best_theta.values, dtype=float)
        return self.belief.summary(truth=truth, best=best) + "\n" + tail + (f"\nwarning: {warn}" if warn else "")

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the result to one netCDF4 file: root (config, best θ), groups ``belief`` and ``history``."""
        path = os.fspath(path)
        root = xr.Dataset(attrs={"config": json.dumps(self.config), "best_error": float(self.best_error),
                                 "format": FORMAT})
        root["best_theta"] = self.best_theta
        root.to_netcdf(path, mode="w", engine="netcdf4")
        if self.belief is not None:
            self.belief.to_dataset().to_netcdf(path, mode="a", group="belief", engine="netcdf4")
        self.history.to_netcdf(path, mode="a", group="history", engine="netcdf4")

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> IdentificationResult:
        """Read a file written by :meth:`save`."""
        path = os.fspath(path)
        if not os.path.exists(path):
            raise BeliefError(f"no result file at {path!r}; write one with IdentificationResult.save(path).")
        with xr.open_dataset(path, engine="netcdf4") as root:
            root = root.load()
        if root.attrs.get("format") != FORMAT:
            raise BeliefError(f"{path!r} is not a tensegrid identification result of format {FORMAT!r} "
                              f"(found {root.attrs.get('format')!r}); re-run the identification.")
        import netCDF4

        with netCDF4.Dataset(path) as nc:
            groups = set(nc.groups)
        belief = Belief.load(path, group="belief") if "belief" in groups else None
        with xr.open_dataset(path, group="history", engine="netcdf4") as hist:
            hist = hist.load()
        for name in ("status", "message"):
            hist[name] = hist[name].astype(str)
        return cls(belief=belief, history=hist, best_theta=root["best_theta"],
                   best_error=float(root.attrs["best_error"]), config=json.loads(root.attrs["config"]))
