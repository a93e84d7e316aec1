"""The posterior as an object: ``Belief``, what planners and model criticism consume.

A Belief holds, for the n cells of a latent grid (``Grid`` or ``SobolCandidates``) and D parameters:

- ``P``: the posterior over the cells, an ``xarray.DataArray`` over the grid's dims (``z0 ..
  z{d-1}`` or ``cell``), >= 0, summing to 1; ``p`` is the same as a flat vector ``n`` in cell order;
- ``theta``: the decoded centre of every cell, ``n x D`` (row k = decoder.decode(grid.points[k]));
- ``space``: the :class:`~physics.parameters.ParameterSpace` (names, units, nominal, bounds, ...);
- ``decoder_config`` and ``grid_config``: JSON-able configurations, so that :meth:`decoder` and
  :meth:`grid` rebuild exactly the decoder and the cells that produced it;
- ``verdict`` and ``reason``: per parameter, "identified", "weakly identified" or "not
  identified" and why (given by whoever builds the Belief, e.g. :mod:`belief.assess`; by default
  from P alone, see :func:`default_verdicts`); a reason starts with the name of the verdict rule
  that decided it (:data:`belief.verdicts.RULES`), read back as :attr:`Belief.rules`;
- ``attrs``: free-form JSON-able provenance (noise rule, σ², warnings, ...); ``attrs["at_bounds"]``
  lists the parameters pinned at a bound of the box after fitting (:mod:`belief.bounds`, the "at
  bound" verdict rule), read back as :attr:`Belief.at_bounds` and shown in :meth:`Belief.summary`;
- ``spread``: optionally the local std of one cell (:class:`belief.spread.CellSpread`, the best
  evaluated cell's Laplace width): its mass counts as a truncated normal in the marginals, so an
  interval is never narrower than the data's local width when one cell holds most of P.

It is used without re-running anything: :meth:`sample` draws θ with probability P (a draw is a
cell's decoded centre, so draws are discrete on the n cells, spread or not), :meth:`marginals` gives per-parameter
mean, std, credible interval, MAP, prior moments and verdicts (numbers from
:func:`belief.posterior.marginals`). It saves to one netCDF file (:meth:`save`, :meth:`load`,
format attribute ``"tensegrid.belief/1"``) or into a group of another file (:meth:`to_dataset`,
:meth:`from_dataset`); configurations and attrs travel as JSON strings, verdicts and reasons as
string variables, so the round trip is exact.
"""
from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from belief.bounds import AT_BOUND_TOLERANCE, AtBound, entries_from_records, inadequacy_text
from belief.errors import BeliefError
from belief.grid import CandidateSet, candidates_from_config
from belief.posterior import entropy, marginals
from belief.serial import jsonable, short, space_from_dataset, space_variables
from belief.spread import CellSpread, ComplementSpread, complement_draws, spread_draws
from belief.verdicts import VERDICTS, default_verdicts, rule_of
from embeddings import Decoder, decoder_from_config
from physics.parameters import ParameterSpace

__all__ = ["Belief", "FORMAT", "SUM_TOLERANCE", "default_verdicts"]

#: value of the ``format`` attribute of a saved belief
FORMAT = "tensegrid.belief/1"
#: |sum(P) - 1| allowed by the constructor
SUM_TOLERANCE = 1e-6


def _check_p(P: xr.DataArray | np.ndarray, grid: CandidateSet) -> xr.DataArray:
    """P as the canonical DataArray "P" over ``grid`` (its coordinates), after validation."""
    template = grid.to_dataarray(np.zeros(grid.size))
    if isinstance(P, xr.DataArray):
        if P.dims != template.dims or P.shape != template.shape:
            raise BeliefError(f"P must be a DataArray over the grid's dims {template.dims} with shape "
                              f"{template.shape}, got dims {P.dims} with shape {P.shape}; build it with "
                              "grid.to_dataarray(p).")
        for name, coord in template.coords.items():
            if name in P.coords and not np.allclose(P[name].values, coord.values, rtol=1e-12, atol=0.0):
                raise BeliefError(f"P's coordinate {name!r} differs from the grid's (grid_config); P belongs to "
                                  "another grid: build it with grid.to_dataarray(p) on the grid of grid_config.")
        values, attrs = np.asarray(P.values), dict(P.attrs)
    else:
        values, attrs = np.asarray(P), {}
        if values.size != grid.size:
            raise BeliefError(f"P must hold one probability per cell ({grid.size}, in cell order), got an array "
                              f"of shape {values.shape}.")
    if not np.issubdtype(values.dtype, np.number) or np.issubdtype(values.dtype, np.complexfloating):
        raise BeliefError(f"P must hold real probabilities, got dtype {values.dtype}.")
    p = values.astype(float).ravel()
    finite = np.isfinite(p)
    if not finite.all() or np.any(p[finite] < 0):
        low = float(p[finite].min()) if finite.any() else float("nan")
        raise BeliefError(f"P must be finite and >= 0 in every cell, got {int(np.sum(~finite))} non-finite and "
                          f"{int(np.sum(p[finite] < 0))} negative values (min {low!r}); clip or recompute it.")
    if abs(p.sum() - 1.0) > SUM_TOLERANCE:
        raise BeliefError(f"P must sum to 1 (within {SUM_TOLERANCE:g}), got {float(p.sum())!r}; normalize it with "
                          "P / P.sum().")
    out = grid.to_dataarray(p, name="P")
    out.attrs = jsonable(attrs, "P.attrs")
    return out


def _check_verdicts(verdicts: Sequence[str] | None, reasons: Sequence[str] | None,
                    marg: Callable[[], xr.Dataset], dim: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    if verdicts is None and reasons is None:
        verdicts, reasons = default_verdicts(marg())
    elif verdicts is None or reasons is None:
        given = "verdicts" if reasons is None else "reasons"
        raise BeliefError(f"{given} given without {'reasons' if reasons is None else 'verdicts'}: give both (one of "
                          f"each per parameter) or neither (defaults from P alone).")
    v, r = list(verdicts), list(reasons)
    if isinstance(verdicts, str) or isinstance(reasons, str) or len(v) != dim or len(r) != dim:
        raise BeliefError(f"give one verdict and one reason per parameter ({dim}), got {short(verdicts)} and "
                          f"{short(reasons)}.")
    bad = sorted({str(x) for x in v} - set(VERDICTS))
    if bad or not all(isinstance(x, str) for x in r):
        raise BeliefError(f"verdicts must be among {list(VERDICTS)} and reasons strings, got verdicts {bad or v} and "
                          f"reason types {sorted({type(x).__name__ for x in r})}.")
    return tuple(str(x) for x in v), tuple(r)


def _spread_from(record: Mapping[str, Any]) -> CellSpread | ComplementSpread:
    """The spread a saved belief carries, by its kind."""
    return ComplementSpread.from_dict(record) if record.get("kind") == "complement" else CellSpread.from_dict(record)


class Belief:
    """Posterior P over n cells with the decoded θ (``n x D``), verdicts and provenance (module docstring).

    ``P``: DataArray over the grid's dims (or a flat array ``n`` in cell order), >= 0, sum 1;
    ``theta``: ``n x D``; ``space``: the parameter space of θ; ``decoder_config``/``grid_config``:
    ``decoder.config()`` and ``grid.config()``; ``verdicts``/``reasons``: one per parameter, both or
    neither (default from P alone, :func:`default_verdicts`); ``attrs``: JSON-able dict;
    ``level``: credible level of intervals and summaries; ``grid``: the grid of ``grid_config`` when
    the caller has it (else it is rebuilt from the config); ``spread``: the local std of one cell
    (belief.spread). Raises :class:`BeliefError`.
    """

    def __init__(self, P: xr.DataArray | np.ndarray, theta: np.ndarray, space: ParameterSpace, *,
                 decoder_config: Mapping[str, Any], grid_config: Mapping[str, Any],
                 verdicts: Sequence[str] | None = None, reasons: Sequence[str] | None = None,
                 attrs: Mapping[str, Any] | None = None, level: float = 0.9,
                 grid: CandidateSet | None = None, spread: CellSpread | ComplementSpread | None = None) -> None:
        if not isinstance(space, ParameterSpace):
            raise BeliefError(f"space must be a physics ParameterSpace, got {type(space).__name__}.")
        if not isinstance(decoder_config, Mapping) or not isinstance(decoder_config.get("kind"), str):
            raise BeliefError(f"decoder_config must be decoder.config() (a dict with a 'kind'), got "
                              f"{short(decoder_config)}.")
        if not isinstance(grid_config, Mapping):
            raise BeliefError(f"grid_config must be grid.config() (a dict), got {short(grid_config)}.")
        if attrs is not None and not (isinstance(attrs, Mapping) and all(isinstance(k, str) for k in attrs)):
            raise BeliefError(f"attrs must be a dict with string keys (JSON-able), got {short(attrs)}.")
        if not (isinstance(level, (int, float)) and 0 < level < 1):
            raise BeliefError(f"level must lie in (0, 1), e.g. 0.9, got {level!r}.")
        self.decoder_config = jsonable(dict(decoder_config), "decoder_config")
        self.grid_config = jsonable(dict(grid_config), "grid_config")
        self.attrs: dict[str, Any] = jsonable(dict(attrs or {}), "attrs")
        if grid is not None and jsonable(dict(grid.config()), "grid.config()") != self.grid_config:
            raise BeliefError("grid differs from grid_config; pass the grid whose config() is grid_config, or no grid.")
        self.P = _check_p(P, grid if grid is not None else candidates_from_config(self.grid_config))
        th = np.array(theta, dtype=float)
        if th.shape != (self.P.size, space.dim) or not np.all(np.isfinite(th)):
            raise BeliefError(f"theta must be finite with shape ({self.P.size}, {space.dim}) (one decoded θ per cell, "
                              f"decoder.decode(grid.points)), got shape {th.shape}.")
        th.setflags(write=False)
        self.theta, self.space, self.level = th, space, float(level)
        if isinstance(spread, ComplementSpread):
            if len(spread.std) != space.dim:
                raise BeliefError(f"a ComplementSpread needs a {space.dim} x {space.dim} covariance, got "
                                  f"{len(spread.std)} x {len(spread.std)}.")
        elif spread is not None and (not isinstance(spread, CellSpread) or spread.cell >= self.P.size
                                     or len(spread.std) != space.dim):
            raise BeliefError(f"spread must be a CellSpread of one of the {self.P.size} cells with {space.dim} stds, "
                              f"or a ComplementSpread, got {short(spread)}.")
        self.spread = spread
        self.verdict, self.reason = _check_verdicts(verdicts, reasons, lambda: self._numbers(self.level), space.dim)
        entries_from_records(self.attrs.get("at_bounds"), space.names)    # fails early on corrupt records

    @classmethod
    def from_posterior(cls, P: xr.DataArray, decoder: Decoder, grid: CandidateSet, *,
                       verdicts: Sequence[str] | None = None, reasons: Sequence[str] | None = None,
                       attrs: Mapping[str, Any] | None = None, level: float = 0.9) -> Belief:
        """Belief of P over ``grid`` with θ = ``decoder.decode(grid.points)`` (``n x D``)."""
        if not isinstance(P, xr.DataArray):
            raise BeliefError(f"P must be an xarray.DataArray over the grid's dims {grid.dims} "
                              f"(posterior_from_surrogate or grid.to_dataarray), got {type(P).__name__}.")
        if decoder.dim != grid.dim:
            raise BeliefError(f"the grid has {grid.dim} latent dims but the decoder {decoder.dim}; build the grid "
                              "with Grid.for_decoder(decoder).")
        theta = decoder.decode(np.asarray(grid.points))
        return cls(P, theta, decoder.space, decoder_config=decoder.config(), grid_config=grid.config(),
                   verdicts=verdicts, reasons=reasons, attrs=attrs, level=level, grid=grid)

    # ------------------------------------------------------------------ reading it
    @property
    def p(self) -> np.ndarray:
        """P as a flat read-only vector ``n`` in cell order (the rows of ``theta``)."""
        v = np.asarray(self.P.values, dtype=float).ravel()
        v.setflags(write=False)
        return v

    @property
    def n_cells(self) -> int:
        """Number of cells n."""
        return int(self.P.size)

    def _numbers(self, level: float) -> xr.Dataset:
        return marginals(self.P, self.theta, self.space, level=level, spread=self.spread).drop_vars("identified")

    def marginals(self, level: float | None = None) -> xr.Dataset:
        """Per parameter (Dataset over ``parameter``, coordinate ``unit``): ``mean``, ``std``, ``lower``,
        ``upper`` (the ``level`` interval, default ``self.level``), ``map``, ``prior_mean``, ``prior_std``
        (numbers of :func:`belief.posterior.marginals`), ``verdict``, ``reason``, ``identified`` and
        ``at_bound`` ("lower" or "upper" for a parameter pinned at that bound, else "")."""
        m = self._numbers(self.level if level is None else level)
        m["verdict"] = ("parameter", np.array(self.verdict, dtype=object))
        m["reason"] = ("parameter", np.array(self.reason, dtype=object))
        m["identified"] = ("parameter", self.identified)
        sides = {a.name: a.side for a in self.at_bounds}
        m["at_bound"] = ("parameter", np.array([sides.get(n, "") for n in self.space.names], dtype=object))
        m.attrs = {"level": float(self.level if level is None else level)}
        return m

    def interval(self, level: float | None = None) -> np.ndarray:
        """Credible intervals ``D x 2``: the (1 - level)/2 and (1 + level)/2 quantiles of each marginal."""
        m = self._numbers(self.level if level is None else level)
        return np.column_stack([m["lower"].values, m["upper"].values])

    @property
    def mean(self) -> np.ndarray:
        """Posterior mean θ = Σ_k p_k θ_k, shape ``D``."""
        return self.p @ self.theta

    @property
    def map(self) -> np.ndarray:
        """θ of the most probable cell, shape ``D`` (ties: the first cell)."""
        return self.theta[int(np.argmax(self.p))].copy()

    @property
    def identified(self) -> np.ndarray:
        """Boolean ``D``: verdict == "identified"."""
        return np.array([v == VERDICTS[0] for v in self.verdict], dtype=bool)

    @property
    def at_bounds(self) -> tuple[AtBound, ...]:
        """Parameters pinned at a bound of the box after fitting (attrs["at_bounds"], the "at bound" verdict rule)."""
        return entries_from_records(self.attrs.get("at_bounds"), self.space.names)

    @property
    def verdicts(self) -> dict[str, tuple[str, str]]:
        """parameter name -> (verdict, reason)."""
        return {n: (v, r) for n, v, r in zip(self.space.names, self.verdict, self.reason, strict=True)}

    @property
    def rules(self) -> list[str]:
        """The verdict rule that decided each parameter's verdict (belief.verdicts.RULES; "" when its
        reason names none), read from the reasons: shape ``D``."""
        return [rule_of(r) for r in self.reason]

    def overruled(self, changes: Mapping[str, tuple[str, str]]) -> Belief:
        """This Belief with the verdicts of some parameters replaced: name -> (verdict, reason). A
        rule that needs what P cannot hold (criticism's "structure" rule: the value under another
        model) may only weaken a verdict, never strengthen it. Raises :class:`BeliefError`."""
        verdicts, reasons = list(self.verdict), list(self.reason)
        for name, (verdict, reason) in changes.items():
            if name not in self.space.names or verdict not in VERDICTS:
                raise BeliefError(f"overruled needs parameters of {list(self.space.names)} and verdicts among "
                                  f"{list(VERDICTS)}, got {name!r}: {verdict!r}.")
            j = self.space.index(name)
            if VERDICTS.index(verdict) < VERDICTS.index(verdicts[j]):
                raise BeliefError(f"overruled may only weaken a verdict: {name} is {verdicts[j]!r}, not {verdict!r}.")
            verdicts[j], reasons[j] = verdict, reason
        return Belief(self.P, self.theta, self.space, decoder_config=self.decoder_config, grid_config=self.grid_config,
                      verdicts=verdicts, reasons=reasons, attrs=self.attrs, level=self.level, spread=self.spread)

    def entropy(self) -> float:
        """Shannon entropy -Σ P log P of P over the cells [nats] (0 for one cell, log n for uniform P)."""
        return entropy(self.P)

    def sample_cells(self, n: int, *, seed: int | np.random.Generator) -> np.ndarray:
        """Indices of n cells drawn i.i.d. with probability P, shape ``n`` (int64);
        ``numpy.random.default_rng(seed)``."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise BeliefError(f"n must be an integer >= 0 (number of draws), got {n!r}.")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer, np.random.Generator)):
            raise BeliefError(f"seed must be an int or a numpy.random.Generator (same seed, same draws), got {seed!r}.")
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(int(seed))
        p = self.p
        return rng.choice(p.size, size=int(n), p=p / p.sum()).astype(np.int64)

    def sample(self, n: int, *, seed: int | np.random.Generator) -> np.ndarray:
        """n draws of θ, ``n x D``: cells drawn with probability P (:meth:`sample_cells`), θ = their decoded
        centres; draws of a spread cell with a local covariance come from its truncated normal
        (belief.spread.spread_draws), and every draw of a local belief carries a draw of its complement
        (belief.spread.complement_draws), so they keep the local posterior's correlations."""
        cells = self.sample_cells(n, seed=seed)
        out = self.theta[cells].copy()
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng([int(seed), 1])
        if isinstance(self.spread, ComplementSpread):
            return complement_draws(self.spread, out, self.space.lower, self.space.upper, rng)
        if self.spread is not None and self.spread.cov is not None:
            hit = cells == self.spread.cell
            out[hit] = spread_draws(self.spread, self.theta[self.spread.cell], self.space.lower, self.space.upper,
                                    int(hit.sum()), rng)
        return out

    def decoder(self) -> Decoder:
        """The decoder that produced this belief, rebuilt by ``embeddings.decoder_from_config`` (checked equal)."""
        return decoder_from_config(self.decoder_config, self.space)

    def grid(self) -> CandidateSet:
        """The Grid or SobolCandidates of the cells, rebuilt from ``grid_config`` (``candidates_from_config``)."""
        return candidates_from_config(self.grid_config)

    def summary(self, truth: np.ndarray | Sequence[float] | None = None,
                best: np.ndarray | Sequence[float] | None = None) -> str:
        """Plain-text table: one row per parameter (unit, mean, interval, verdict; a ``best`` column, the
        best θ of the run, and a ``truth`` column if given); a parameter pinned at a bound has "(at
        lower/upper bound)" after its verdict, and the "Model inadequacy" block
        (belief.bounds.inadequacy_text) follows the table."""
        m = self.marginals()
        tr, bt = (None if v is None else np.asarray(v, dtype=float) for v in (truth, best))
        for label, v in (("truth", tr), ("best", bt)):
            if v is not None and v.shape != (self.space.dim,):
                raise BeliefError(f"{label} must have shape ({self.space.dim},) in the order "
                                  f"{list(self.space.names)}, got {v.shape}.")
        head = f"{'parameter':<17}{'unit':<9}{'mean':>11}{'lower':>11}{'upper':>11}"
        lines = [head + (f"{'best':>11}" if bt is not None else "") + (f"{'truth':>11}" if tr is not None else "")
                 + "  verdict"]
        for j, name in enumerate(self.space.names):
            lo, hi = m["lower"].values[j], m["upper"].values[j]
            row = f"{name:<17}{self.space.units[j]:<9}{m['mean'].values[j]:>11.5g}{lo:>11.5g}{hi:>11.5g}"
            if bt is not None:
                row += f"{bt[j]:>11.5g}"
            if tr is not None:
                row += f"{tr[j]:>10.5g}{' ' if lo <= tr[j] <= hi else '!'}"
            side = m["at_bound"].values[j]
            lines.append(row + f"  {self.verdict[j]}" + (f" (at {side} bound)" if side else ""))
        how = {CellSpread: " (the best evaluated cell spread by its local width)",
               ComplementSpread: " (local grid at the data's resolution; the other directions spread by their "
                                 "local posterior)"}.get(type(self.spread), "")
        lines.append(f"{self.level:.0%} credible intervals" + how
                     + "; verdict reasons: Belief.verdicts"
                     + ("; '!' marks a truth outside the interval" if tr is not None else ""))
        block = inadequacy_text(self.at_bounds, tolerance=self.attrs.get("bound_tolerance", AT_BOUND_TOLERANCE))
        return "\n".join(lines + ([block] if block else []))

    def __repr__(self) -> str:
        ident = [n for n, v in zip(self.space.names, self.verdict, strict=True) if v == VERDICTS[0]]
        return f"Belief({self.n_cells} cells, {self.space.dim} parameters, identified: {ident or 'none'})"

    # ------------------------------------------------------------------ files
    def to_dataset(self) -> xr.Dataset:
        """Everything in one Dataset: ``P`` over the grid dims, ``theta`` (cell_index, parameter), the
        space's fields, ``verdict`` and ``reason`` over ``parameter``; configurations, P's attrs and
        ``attrs`` as JSON string attributes; ``format`` = :data:`FORMAT`."""
        P = self.P.copy()
        P.attrs = {}
        coords, space_vars = space_variables(self.space)
        ds = xr.Dataset({"P": P, "theta": (("cell_index", "parameter"), np.asarray(self.theta)),
                         "verdict": ("parameter", np.array(self.verdict, dtype=object)),
                         "reason": ("parameter", np.array(self.reason, dtype=object)), **space_vars},
                        coords=coords)
        ds.attrs = {"format": FORMAT, "level": self.level, "P_dims": json.dumps(list(self.P.dims)),
                    "P_attrs": json.dumps(self.P.attrs),
                    "decoder_config": json.dumps(self.decoder_config), "grid_config": json.dumps(self.grid_config),
                    "attrs": json.dumps(self.attrs)}
        if self.spread is not None:
            ds.attrs["spread"] = json.dumps(self.spread.as_dict())
        return ds

    @classmethod
    def from_dataset(cls, ds: xr.Dataset) -> Belief:
        """Inverse of :meth:`to_dataset`; a Dataset that is not a belief raises :class:`BeliefError`."""
        if not isinstance(ds, xr.Dataset) or ds.attrs.get("format") != FORMAT:
            found = ds.attrs.get("format") if isinstance(ds, xr.Dataset) else type(ds).__name__
            raise BeliefError(f"not a tensegrid belief (format attribute {found!r}, expected {FORMAT!r}); "
                              "write one with Belief.save or Belief.to_dataset.")
        missing = [k for k in ("P", "theta", "verdict", "reason") if k not in ds.variables]
        missing += [k for k in ("level", "P_dims", "decoder_config", "grid_config", "attrs") if k not in ds.attrs]
        if missing:
            raise BeliefError(f"the belief Dataset lacks {missing}; it was not written by Belief.to_dataset.")
        try:
            P = ds["P"].transpose(*json.loads(ds.attrs["P_dims"]))
            P.attrs = json.loads(ds.attrs["P_attrs"]) if "P_attrs" in ds.attrs else dict(ds["P"].attrs)
            configs = [json.loads(ds.attrs[k]) for k in ("decoder_config", "grid_config", "attrs")]
            spread = _spread_from(json.loads(ds.attrs["spread"])) if "spread" in ds.attrs else None
        except (ValueError, TypeError) as exc:
            raise BeliefError(f"the belief Dataset has a corrupt attribute ({exc}); re-save the belief.") from None
        return cls(P, ds["theta"].values, space_from_dataset(ds), decoder_config=configs[0], grid_config=configs[1],
                   verdicts=[str(v) for v in ds["verdict"].values], reasons=[str(r) for r in ds["reason"].values],
                   attrs=configs[2], level=float(ds.attrs["level"]), spread=spread)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write to one netCDF4 file (xarray, engine netcdf4), overwriting ``path``."""
        self.to_dataset().to_netcdf(os.fspath(path), mode="w", engine="netcdf4")

    @classmethod
    def load(cls, path: str | os.PathLike[str], *, group: str | None = None) -> Belief:
        """Read a file written by :meth:`save` (or the netCDF ``group`` of a file that embeds one)."""
        path = os.fspath(path)
        if not os.path.exists(path):
            raise BeliefError(f"no belief file at {path!r}; write one with Belief.save(path).")
        try:
            with xr.open_dataset(path, engine="netcdf4", group=group) as ds:
                ds = ds.load()
        except (OSError, ValueError, KeyError) as exc:
            raise BeliefError(f"{path!r} is not a readable netCDF belief{'' if group is None else f' group {group!r}'} "
                              f"({exc}); write one with Belief.save(path).") from None
        return cls.from_dataset(ds)
