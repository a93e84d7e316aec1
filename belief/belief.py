"""The posterior as an object: ``Belief``, what planners and model criticism consume.

A Belief holds, for n cells of a latent grid:

- ``P``: the posterior over the cells (DataArray over the grid's dims, >= 0, sums to 1);
- ``theta``: the decoded θ of every cell, ``n x D`` (cell order = ``P.values.ravel()``);
- the ParameterSpace, the decoder's and the grid's configurations (so :meth:`decoder` and
  :meth:`grid` rebuild exactly the ones that produced it);
- a verdict per parameter ("identified", "weakly identified", "not identified") with its reason
  (belief.verdicts), and ``attrs`` (noise rule, σ², warnings: JSON-able).

It is used without re-running anything: :meth:`sample` draws θ (cells with probability P),
:meth:`marginals` gives per-parameter mean, std, credible interval, MAP and verdict. It saves to
one netCDF file (:meth:`save`, :meth:`load`) or into a group of another (:meth:`to_dataset`).
"""
from __future__ import annotations

import json
import os
from typing import Any, Sequence

import numpy as np
import xarray as xr

from belief.errors import BeliefError
from belief.grid import candidates_from_config
from belief.posterior import entropy, marginals
from belief.verdicts import VERDICTS
from physics.parameters import Parameter, ParameterSpace

__all__ = ["Belief", "FORMAT"]

FORMAT = "tensegrid.belief/1"


def _default_verdicts(marg: xr.Dataset) -> tuple[list[str], list[str]]:
    """From P alone: std/prior_std < 0.5 identified, < 0.8 weakly, else not (no evidence checks)."""
    ratio = marg["std"].values / np.maximum(marg["prior_std"].values, 1e-300)
    verdicts = [VERDICTS[0] if r < 0.5 else VERDICTS[1] if r < 0.8 else VERDICTS[2] for r in ratio]
    return verdicts, [f"std is {r:.0%} of the prior's (P alone, no further evidence)" for r in ratio]


class Belief:
    """Posterior P over cells with the decoded θ, verdicts and provenance (module docstring).

    ``P``: DataArray over the grid dims; ``theta``: ``n x D``; ``verdicts``/``reasons``: one per
    parameter (default from P alone); ``level``: credible level of intervals and summaries.
    """

    def __init__(self, P: xr.DataArray, theta: np.ndarray, space: ParameterSpace, *, decoder_config: dict[str, Any],
                 grid_config: dict[str, Any], verdicts: Sequence[str] | None = None,
                 reasons: Sequence[str] | None = None, attrs: dict[str, Any] | None = None, level: float = 0.9) -> None:
        p = np.asarray(P.values, dtype=float).ravel()
        th = np.asarray(theta, dtype=float)
        if p.size == 0 or not np.all(np.isfinite(p)) or np.any(p < 0):
            raise BeliefError("P must be a non-empty array of finite, non-negative probabilities.")
        if abs(p.sum() - 1.0) > 1e-6:
            raise BeliefError(f"P must sum to 1, got {p.sum()!r}; normalize it first.")
        if th.shape != (p.size, space.dim):
            raise BeliefError(f"theta must have shape ({p.size}, {space.dim}) (one decoded θ per cell), got {th.shape}.")
        if not (0 < level < 1):
            raise BeliefError(f"level must lie in (0, 1), e.g. 0.9, got {level!r}.")
        self.P, self.theta, self.space, self.level = P, th, space, float(level)
        self.decoder_config, self.grid_config = dict(decoder_config), dict(grid_config)
        self.attrs = dict(attrs or {})
        if verdicts is None:
            verdicts, default_reasons = _default_verdicts(self._numbers(self.level))
            reasons = reasons if reasons is not None else default_reasons
        verdicts, reasons = [str(v) for v in verdicts], [str(r) for r in (reasons or [""] * space.dim)]
        if len(verdicts) != space.dim or len(reasons) != space.dim:
            raise BeliefError(f"give one verdict and one reason per parameter ({space.dim}), got "
                              f"{len(verdicts)} and {len(reasons)}.")
        bad = sorted(set(verdicts) - set(VERDICTS))
        if bad:
            raise BeliefError(f"verdicts must be among {VERDICTS}, got {bad}.")
        self.verdict, self.reason = tuple(verdicts), tuple(reasons)

    @classmethod
    def from_posterior(cls, P: xr.DataArray, decoder: Any, grid: Any, *, verdicts: Sequence[str] | None = None,
                       reasons: Sequence[str] | None = None, attrs: dict[str, Any] | None = None,
                       level: float = 0.9) -> "Belief":
        """Belief of P over ``grid``, decoded by ``decoder`` (an embeddings.Decoder)."""
        theta = decoder.decode(np.asarray(grid.points))
        return cls(P, theta, decoder.space, decoder_config=decoder.config(), grid_config=grid.config(),
                   verdicts=verdicts, reasons=reasons, attrs=attrs, level=level)

    # ------------------------------------------------------------------ reading it
    @property
    def p(self) -> np.ndarray:
        """P as a flat vector (n,) in cell order."""
        return np.asarray(self.P.values, dtype=float).ravel()

    def _numbers(self, level: float) -> xr.Dataset:
        return marginals(self.P, self.theta, self.space, level=level)

    def marginals(self, level: float | None = None) -> xr.Dataset:
        """Per parameter: mean, std, lower, upper (``level`` interval), map, prior_mean, prior_std,
        verdict, reason and identified (verdict == "identified"); Dataset over ``parameter``."""
        m = self._numbers(self.level if level is None else level).drop_vars("identified")
        m["verdict"] = ("parameter", np.array(self.verdict, dtype=object))
        m["reason"] = ("parameter", np.array(self.reason, dtype=object))
        m["identified"] = ("parameter", np.array([v == VERDICTS[0] for v in self.verdict]))
        return m

    def interval(self, level: float | None = None) -> np.ndarray:
        """Credible intervals (D x 2): the (1 ∓ level)/2 quantiles of each marginal."""
        m = self._numbers(self.level if level is None else level)
        return np.column_stack([m["lower"].values, m["upper"].values])

    @property
    def mean(self) -> np.ndarray:
        """Posterior mean θ (D,)."""
        return self.p @ self.theta

    @property
    def map(self) -> np.ndarray:
        """θ of the most probable cell (D,)."""
        return self.theta[int(np.argmax(self.p))]

    @property
    def identified(self) -> np.ndarray:
        """Boolean (D,): verdict == "identified"."""
        return np.array([v == VERDICTS[0] for v in self.verdict])

    @property
    def verdicts(self) -> dict[str, tuple[str, str]]:
        """parameter name -> (verdict, reason)."""
        return {n: (v, r) for n, v, r in zip(self.space.names, self.verdict, self.reason)}

    def entropy(self) -> float:
        """Shannon entropy of P over the cells [nats]."""
        return entropy(self.P)

    def sample(self, n: int, *, seed: "int | np.random.Generator") -> np.ndarray:
        """n draws of θ (n x D): cells drawn with probability P, θ = the cell's decoded centre."""
        if not isinstance(n, (int, np.integer)) or n < 0:
            raise BeliefError(f"n must be an integer >= 0 (number of draws), got {n!r}.")
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        return self.theta[rng.choice(self.p.size, size=int(n), p=self.p)]

    def decoder(self) -> Any:
        """The decoder that produced this belief, rebuilt from its configuration."""
        from embeddings.registry import decoder_from_config

        return decoder_from_config(self.decoder_config, self.space)

    def grid(self) -> Any:
        """The grid or candidate set of the cells, rebuilt from its configuration."""
        return candidates_from_config(self.grid_config)

    def summary(self, truth: Sequence[float] | None = None) -> str:
        """Plain-text table: one row per parameter (mean, interval, verdict; ``truth`` column if given)."""
        m = self.marginals()
        head = f"{'parameter':<17}{'unit':<9}{'mean':>11}{'lower':>11}{'upper':>11}"
        head += f"{'truth':>11}" if truth is not None else ""
        lines = [head + "  verdict"]
        for j, name in enumerate(self.space.names):
            row = (f"{name:<17}{self.space.units[j]:<9}{m['mean'].values[j]:>11.5g}{m['lower'].values[j]:>11.5g}"
                   f"{m['upper'].values[j]:>11.5g}")
            if truth is not None:
                inside = m["lower"].values[j] <= truth[j] <= m["upper"].values[j]
                row += f"{truth[j]:>10.5g}{' ' if inside else '!'}"
            lines.append(row + f"  {self.verdict[j]}")
        lines.append(f"{self.level:.0%} credible intervals; verdict reasons: Belief.verdicts"
                     + ("; '!' marks a truth outside the interval" if truth is not None else ""))
        return "\n".join(lines)

    def __repr__(self) -> str:
        ident = [n for n, v in zip(self.space.names, self.verdict) if v == VERDICTS[0]]
        return f"Belief({self.p.size} cells, {self.space.dim} parameters, identified: {ident or 'none'})"

    # ------------------------------------------------------------------ files
    def to_dataset(self) -> xr.Dataset:
        """Everything in one Dataset (P over the grid dims, theta over (cell, parameter), the space,
        verdicts and reasons over parameter; configurations and attrs as JSON attributes)."""
        ps = self.space.parameters
        par = ("parameter",)
        ds = xr.Dataset({
            "P": self.P.rename("P"),
            "theta": (("cell_index", "parameter"), self.theta),
            "verdict": (par, np.array(self.verdict, dtype=object)), "reason": (par, np.array(self.reason, dtype=object)),
            "nominal": (par, [q.nominal for q in ps]), "lower_bound": (par, [q.lower for q in ps]),
            "upper_bound": (par, [q.upper for q in ps]), "minimum": (par, [q.minimum for q in ps]),
            "strict": (par, np.array([int(q.strict) for q in ps], dtype=np.int8)),
            "description": (par, np.array([q.description for q in ps], dtype=object)),
        }, coords={"parameter": list(self.space.names), "unit": ("parameter", list(self.space.units))})
        ds.attrs = {"format": FORMAT, "level": self.level, "P_dims": json.dumps(list(self.P.dims)),
                    "decoder_config": json.dumps(self.decoder_config), "grid_config": json.dumps(self.grid_config),
                    "attrs": json.dumps(self.attrs, default=float)}
        return ds

    @classmethod
    def from_dataset(cls, ds: xr.Dataset) -> "Belief":
        """Inverse of :meth:`to_dataset`."""
        if ds.attrs.get("format") != FORMAT:
            raise BeliefError(f"not a tensegrid belief (format attribute {ds.attrs.get('format')!r}, expected {FORMAT!r}).")
        params = tuple(Parameter(str(n), str(u), float(no), float(lo), float(hi), str(de), float(mi), bool(st))
                       for n, u, no, lo, hi, de, mi, st in zip(
                           ds["parameter"].values, ds["unit"].values, ds["nominal"].values, ds["lower_bound"].values,
                           ds["upper_bound"].values, ds["description"].values, ds["minimum"].values, ds["strict"].values))
        P = ds["P"].transpose(*json.loads(ds.attrs["P_dims"]))
        P.attrs = dict(ds["P"].attrs)
        return cls(P, ds["theta"].values, ParameterSpace(params), decoder_config=json.loads(ds.attrs["decoder_config"]),
                   grid_config=json.loads(ds.attrs["grid_config"]), verdicts=[str(v) for v in ds["verdict"].values],
                   reasons=[str(r) for r in ds["reason"].values], attrs=json.loads(ds.attrs["attrs"]),
                   level=float(ds.attrs["level"]))

    def save(self, path: "str | os.PathLike[str]") -> None:
        """Write to a netCDF4 file (xarray)."""
        self.to_dataset().to_netcdf(os.fspath(path), mode="w", engine="netcdf4")

    @classmethod
    def load(cls, path: "str | os.PathLike[str]", *, group: str | None = None) -> "Belief":
        """Read a file written by :meth:`save` (or the ``group`` of a file that embeds one)."""
        path = os.fspath(path)
        if not os.path.exists(path):
            raise BeliefError(f"no belief file at {path!r}; write one with Belief.save(path).")
        try:
            with xr.open_dataset(path, engine="netcdf4", group=group) as ds:
                ds = ds.load()
        except (OSError, ValueError) as exc:
            raise BeliefError(f"{path!r} is not a readable netCDF belief ({exc}).") from exc
        return cls.from_dataset(ds)
