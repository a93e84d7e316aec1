"""Candidate sets over a decoder's latent box: a regular ``Grid`` and scattered ``SobolCandidates``.

Both implement one contract, the abstract base class :class:`CandidateSet`, which the rest of
belief is typed against (a new kind of candidate set subclasses it):

- ``points``: ``n x d`` float array of cell centres (latent coordinates);
- ``dims``: dimension names of the DataArray a flat vector of length ``n`` becomes
  (``("z0", ..., "z{d-1}")`` for a grid, ``("cell",)`` for scattered points);
- ``to_dataarray(values)``: flat ``n`` vector -> ``xarray.DataArray`` (coordinates = latent values);
- ``bounds`` (``d x 2``), ``dim`` (d), ``size`` (n), ``config()`` (JSON-able, for the journal),
  ``nearest(z)`` (index of the cell nearest to each latent point, ``m x d`` -> ``m``);
- ``from_config(config)`` (classmethod): the candidate set whose ``config()`` equals ``config``.

The paper discretizes Θ with a regular grid (Sec. III); in 15-D a grid is impossible (even 3 points
per axis give 1.4e7 cells), so full-space baselines use a scrambled Sobol set (scipy.stats.qmc).
"""
from __future__ import annotations

import abc
import json
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

import numpy as np
import xarray as xr
from scipy.stats import qmc

from belief.errors import GridError
from embeddings.base import Decoder

__all__ = ["Grid", "SobolCandidates", "CandidateSet", "MAX_CELLS", "candidates_from_config"]

#: refuse grids above this many cells (memory of ``points`` and of the GP prediction)
MAX_CELLS = 20_000_000

_C = TypeVar("_C", bound="CandidateSet")


def _check_bounds(bounds: np.ndarray | Sequence[Sequence[float]]) -> np.ndarray:
    b = np.asarray(bounds, dtype=float)
    if b.ndim != 2 or b.shape[1] != 2 or b.shape[0] < 1:
        raise GridError(f"bounds must have shape (d, 2) with d >= 1 (use decoder.bounds), got {b.shape}.")
    if not np.all(np.isfinite(b)) or np.any(b[:, 0] >= b[:, 1]):
        raise GridError(f"bounds must be finite with lower < upper in every row, got {b.tolist()}.")
    return b


class CandidateSet(abc.ABC):
    """The candidate-set contract (module docstring): n cells of a d-dimensional latent box, with the
    code :class:`Grid` and :class:`SobolCandidates` share; subclasses set ``bounds`` (d x 2) and
    ``_points`` (n x d, read-only) and define the abstract members."""

    bounds: np.ndarray
    _points: np.ndarray

    @property
    @abc.abstractmethod
    def dims(self) -> tuple[str, ...]:
        """Dimension names of the DataArray a flat vector of n values becomes."""

    @abc.abstractmethod
    def to_dataarray(self, values: np.ndarray, *, name: str | None = None) -> xr.DataArray:
        """Flat vector (n) -> DataArray over :attr:`dims` with the latent coordinates."""

    @abc.abstractmethod
    def config(self) -> dict[str, Any]:
        """JSON-able description with ``kind``, from which :meth:`from_config` rebuilds the same cells."""

    @classmethod
    @abc.abstractmethod
    def from_config(cls: type[_C], config: Mapping[str, Any]) -> _C:
        """The candidate set whose ``config()`` equals ``config``."""

    @property
    def dim(self) -> int:
        return int(self.bounds.shape[0])

    @property
    def size(self) -> int:
        return int(self._points.shape[0])

    def __len__(self) -> int:
        return self.size

    @property
    def points(self) -> np.ndarray:
        """Cell centres, ``n x d`` (read-only view)."""
        return self._points

    @property
    def latent_names(self) -> tuple[str, ...]:
        return tuple(f"z{i}" for i in range(self.dim))

    def nearest(self, z: np.ndarray) -> np.ndarray:
        """Index of the nearest cell (Euclidean in latent units) for each row of ``z`` (``m x d`` -> ``m``)."""
        zz = np.atleast_2d(np.asarray(z, dtype=float))
        if zz.shape[1] != self.dim:
            raise GridError(f"nearest expects points of shape (m, {self.dim}), got {np.shape(z)}.")
        out = np.empty(zz.shape[0], dtype=np.int64)
        for i, row in enumerate(zz):
            best, best_d = 0, np.inf
            for s in range(0, self.size, 1 << 18):
                d2 = np.sum((self._points[s:s + (1 << 18)] - row) ** 2, axis=1)
                j = int(np.argmin(d2))
                if d2[j] < best_d:
                    best, best_d = s + j, d2[j]
            out[i] = best
        return out

    def _check_values(self, values: np.ndarray) -> np.ndarray:
        v = np.asarray(values)
        if v.shape != (self.size,):
            raise GridError(f"values must be a flat vector of one value per cell, shape ({self.size},), got {v.shape}.")
        return v


class Grid(CandidateSet):
    """Regular grid over the latent box ``bounds`` (``d x 2``), cell centres on ``points_per_dim`` nodes per axis.

    ``points_per_dim``: an int (same for every axis) or one int per axis, each >= 2; node values
    are ``numpy.linspace(lower, upper, k)``, so box corners are included. ``points`` enumerates the
    cells in C order (last dimension fastest), matching ``to_dataarray``'s reshape.
    """

    def __init__(self, bounds: np.ndarray | Sequence[Sequence[float]], *,
                 points_per_dim: int | Sequence[int] = 11) -> None:
        self.bounds = _check_bounds(bounds)
        d = self.bounds.shape[0]
        ppd = np.asarray(points_per_dim)
        if ppd.ndim == 0:
            ppd = np.broadcast_to(ppd, (d,))
        if ppd.shape != (d,) or not np.issubdtype(ppd.dtype, np.integer):
            raise GridError(f"points_per_dim must be an int or {d} ints, got {points_per_dim!r}.")
        if np.any(ppd < 1):
            raise GridError(f"points_per_dim must be >= 1 on every axis; {points_per_dim!r} gives an empty grid.")
        if np.any(ppd < 2):
            raise GridError("points_per_dim must be >= 2 on every axis (a single node cannot span the box), got "
                            f"{points_per_dim!r}.")
        n = int(np.prod(ppd.astype(float)))
        if n > MAX_CELLS:
            raise GridError(
                f"a grid of {' x '.join(map(str, ppd))} = {n:.3g} cells exceeds MAX_CELLS={MAX_CELLS:.3g}; "
                "use fewer points per dimension, a lower-dimensional decoder, or SobolCandidates."
            )
        self.points_per_dim = tuple(int(k) for k in ppd)
        self.coords = tuple(np.linspace(lo, hi, k)
                            for (lo, hi), k in zip(self.bounds, self.points_per_dim, strict=True))
        mesh = np.meshgrid(*self.coords, indexing="ij")
        self._points = np.stack([m.ravel() for m in mesh], axis=1)
        self._points.setflags(write=False)

    @classmethod
    def for_decoder(cls, decoder: Decoder, *, points_per_dim: int | Sequence[int] = 11) -> Grid:
        """Grid over ``decoder.bounds``."""
        return cls(decoder.bounds, points_per_dim=points_per_dim)

    @property
    def dims(self) -> tuple[str, ...]:
        return self.latent_names

    def nearest(self, z: np.ndarray) -> np.ndarray:
        """Index of the nearest node for each row of ``z`` (``m x d`` -> ``m``), by rounding per axis."""
        zz = np.atleast_2d(np.asarray(z, dtype=float))
        if zz.shape[1] != self.dim:
            raise GridError(f"nearest expects points of shape (m, {self.dim}), got {np.shape(z)}.")
        lo, hi = self.bounds[:, 0], self.bounds[:, 1]
        k = np.asarray(self.points_per_dim)
        idx = np.clip(np.rint((zz - lo) / (hi - lo) * (k - 1)), 0, k - 1).astype(np.int64)
        return np.ravel_multi_index(tuple(idx.T), self.points_per_dim)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.points_per_dim

    def to_dataarray(self, values: np.ndarray, *, name: str | None = None) -> xr.DataArray:
        """Flat vector (``n``) -> DataArray with dims ``z0 .. z{d-1}`` and the node values as coordinates."""
        v = self._check_values(values)
        return xr.DataArray(v.reshape(self.points_per_dim), dims=self.dims,
                            coords={n: c for n, c in zip(self.dims, self.coords, strict=True)}, name=name)

    def config(self) -> dict[str, Any]:
        return {"kind": "grid", "bounds": self.bounds.tolist(), "points_per_dim": list(self.points_per_dim)}

    @classmethod
    def from_config(cls, config: Mapping[str, Any]) -> Grid:
        """The Grid whose ``config()`` equals ``config`` (kind "grid", ``bounds`` d x 2, ``points_per_dim``)."""
        _require(config, "grid", ("bounds", "points_per_dim"))
        return _same_config(cls(config["bounds"], points_per_dim=config["points_per_dim"]), config)


class SobolCandidates(CandidateSet):
    """``n`` scrambled Sobol points in the latent box (``scipy.stats.qmc.Sobol(d, seed=seed)``).

    For dimensions where a regular grid is impossible (e.g. BO in the full 15-D space). Each point
    is a "cell" of equal prior mass; the DataArray dimension is ``cell`` with coordinates z0..z{d-1}.
    ``include`` (k x d) latent points become cells 0..k-1, before the n Sobol points (a warm start,
    e.g. the previous estimate when a model is extended).
    """

    def __init__(self, bounds: np.ndarray | Sequence[Sequence[float]], *, n: int, seed: int,
                 include: np.ndarray | Sequence[Sequence[float]] | None = None) -> None:
        self.bounds = _check_bounds(bounds)
        if not isinstance(n, (int, np.integer)) or n < 1:
            raise GridError(f"SobolCandidates needs n >= 1 points, got {n!r} (an empty candidate set).")
        if n > MAX_CELLS:
            raise GridError(f"n={n} exceeds MAX_CELLS={MAX_CELLS}; use fewer candidates.")
        if not isinstance(seed, (int, np.integer)):
            raise GridError(f"SobolCandidates seed must be an integer, got {seed!r}.")
        self.n, self.seed = int(n), int(seed)
        sampler = qmc.Sobol(self.dim, scramble=True, seed=self.seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # balance warning when n is not a power of two
            u = sampler.random(self.n)
        points = qmc.scale(u, self.bounds[:, 0], self.bounds[:, 1])
        extra = np.empty((0, self.dim)) if include is None else np.atleast_2d(np.asarray(include, dtype=float))
        if extra.size and (extra.shape[1] != self.dim or np.any(extra < self.bounds[:, 0] - 1e-12)
                           or np.any(extra > self.bounds[:, 1] + 1e-12) or not np.all(np.isfinite(extra))):
            raise GridError(f"include must be finite points (k x {self.dim}) inside the latent box, got shape "
                            f"{extra.shape}.")
        self.include = np.clip(extra, self.bounds[:, 0], self.bounds[:, 1]).reshape(-1, self.dim)
        self._points = np.vstack([self.include, points])
        self._points.setflags(write=False)

    @classmethod
    def for_decoder(cls, decoder: Decoder, *, n: int, seed: int) -> SobolCandidates:
        return cls(decoder.bounds, n=n, seed=seed)

    @property
    def dims(self) -> tuple[str, ...]:
        return ("cell",)

    def to_dataarray(self, values: np.ndarray, *, name: str | None = None) -> xr.DataArray:
        """Flat vector (``n``) -> DataArray over ``cell`` with non-index coordinates ``z0 .. z{d-1}``."""
        v = self._check_values(values)
        coords: dict[str, Any] = {"cell": np.arange(self.size)}
        coords.update({zn: ("cell", self._points[:, i]) for i, zn in enumerate(self.latent_names)})
        return xr.DataArray(v, dims=("cell",), coords=coords, name=name)

    def config(self) -> dict[str, Any]:
        out = {"kind": "sobol", "bounds": self.bounds.tolist(), "n": self.n, "seed": self.seed}
        if len(self.include):
            out["include"] = self.include.tolist()
        return out

    @classmethod
    def from_config(cls, config: Mapping[str, Any]) -> SobolCandidates:
        """The SobolCandidates whose ``config()`` equals ``config`` (kind "sobol", ``bounds``, ``n``, ``seed``)."""
        _require(config, "sobol", ("bounds", "n", "seed"))
        return _same_config(cls(config["bounds"], n=config["n"], seed=config["seed"],
                                include=config.get("include")), config)


_KINDS: dict[str, type[CandidateSet]] = {"grid": Grid, "sobol": SobolCandidates}


def candidates_from_config(config: Mapping[str, Any]) -> CandidateSet:
    """The Grid or SobolCandidates whose ``config()`` equals ``config`` (a saved belief's grid), by its ``kind``."""
    kind = config.get("kind") if isinstance(config, Mapping) else None
    if kind not in _KINDS:
        raise GridError(f"unknown candidate-set kind {kind!r} in the saved configuration; expected one of "
                        f"{sorted(_KINDS)} (a dict from Grid.config() or SobolCandidates.config()).")
    return _KINDS[kind].from_config(config)


def _require(config: object, kind: str, keys: tuple[str, ...]) -> None:
    if not isinstance(config, Mapping) or config.get("kind") != kind:
        got = config.get("kind") if isinstance(config, Mapping) else type(config).__name__
        raise GridError(f"config must be a dict with kind {kind!r} (from config()), got {got!r}.")
    missing = [k for k in keys if k not in config]
    if missing:
        raise GridError(f"the saved {kind} configuration lacks {missing} (has {sorted(config)}); "
                        "save it with config().")


def _jsonable(value: object) -> object:
    """numpy arrays and scalars as lists and numbers, anything else as its str (json.dumps default)."""
    return value.tolist() if isinstance(value, (np.ndarray, np.generic)) else str(value)


def _same_config(cells: _C, config: Mapping[str, Any]) -> _C:
    """``cells``, after checking that its config() equals ``config`` (compared as JSON)."""
    rebuilt = json.loads(json.dumps(cells.config()))
    saved = json.loads(json.dumps(dict(config), default=_jsonable))
    if rebuilt != saved:
        keys = sorted(k for k in set(rebuilt) | set(saved) if rebuilt.get(k) != saved.get(k))
        raise GridError(f"the rebuilt candidate set differs from the saved configuration in {keys}: saved "
                        f"{[saved.get(k) for k in keys]}, rebuilt {[rebuilt.get(k) for k in keys]}; "
                        "give the configuration as config() wrote it.")
    return cells
