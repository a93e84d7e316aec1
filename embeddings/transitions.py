"""Training data of a dynamics network: rows (θ, context, target) from simulations.

A :class:`Transitions` holds ``n`` rows::

    theta    (n, D)   physical parameters that generated the row          [units of the space]
    context  (n, c)   what the next state depends on besides θ: state and action features
    target   (n, k)   the simulated summary of the next state (e.g. centre-of-mass displacement)
    group    (n,)     which simulated trajectory the row came from (held-out splits keep groups whole)

and saves to / loads from netCDF (:meth:`Transitions.save`, :meth:`Transitions.load`), so an
expensive set is simulated once and reused. :func:`push_transitions` makes the 1-D push toy's set
(paper Sec. IV-C-1: θ = (m, μ), context = the impulse F t, target = the displacement S);
:mod:`embeddings.t6_data` makes the SUPERball's.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from embeddings.errors import EmbeddingError
from physics.parameters import ParameterSpace

__all__ = ["Transitions", "push_transitions"]


@dataclass(frozen=True)
class Transitions:
    """Rows (θ, context, target, group) of simulated transitions; see the module docstring for shapes."""

    theta: np.ndarray
    context: np.ndarray
    target: np.ndarray
    group: np.ndarray
    parameter_names: tuple[str, ...]
    context_names: tuple[str, ...]
    target_names: tuple[str, ...]
    attrs: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.theta)
        shapes = {"theta": (self.theta, len(self.parameter_names)), "context": (self.context, len(self.context_names)),
                  "target": (self.target, len(self.target_names))}
        for name, (arr, width) in shapes.items():
            if np.ndim(arr) != 2 or arr.shape != (n, width):
                raise EmbeddingError(f"Transitions.{name} must have shape ({n}, {width}), got {np.shape(arr)}.")
            if not np.all(np.isfinite(arr)):
                raise EmbeddingError(f"Transitions.{name} holds NaN or inf; drop diverged simulations first.")
        if np.shape(self.group) != (n,):
            raise EmbeddingError(f"Transitions.group must have shape ({n},), got {np.shape(self.group)}.")
        if n < 2:
            raise EmbeddingError(f"Transitions need at least two rows, got {n}.")

    def __len__(self) -> int:
        return len(self.theta)

    def rows(self, index: np.ndarray) -> Transitions:
        """The subset of rows ``index`` (boolean mask or integer indices)."""
        return Transitions(self.theta[index], self.context[index], self.target[index], self.group[index],
                           self.parameter_names, self.context_names, self.target_names, dict(self.attrs))

    def split(self, held_out: float = 0.2, *, seed: int = 0) -> tuple[Transitions, Transitions]:
        """(train, test): a seeded random ``held_out`` fraction of the *groups* goes to test."""
        groups = np.unique(self.group)
        if not 0 < held_out < 1 or len(groups) < 2:
            raise EmbeddingError(f"split needs 0 < held_out < 1 and two or more groups, got {held_out!r} and "
                                 f"{len(groups)} groups.")
        rng = np.random.default_rng(seed)
        n_test = min(len(groups) - 1, max(1, int(round(held_out * len(groups)))))
        test = np.isin(self.group, rng.choice(groups, n_test, replace=False))
        return self.rows(~test), self.rows(test)

    def unit_theta(self, space: ParameterSpace) -> np.ndarray:
        """θ in the unit coordinates of ``space`` (n, D); its names must be this set's."""
        if tuple(space.names) != tuple(self.parameter_names):
            raise EmbeddingError(f"these transitions were made on parameters {list(self.parameter_names)}, "
                                 f"not {list(space.names)}; generate them on this space.")
        return space.to_unit(self.theta)

    def to_dataset(self) -> xr.Dataset:
        """The rows as an xarray Dataset (dims row, parameter, feature, output)."""
        return xr.Dataset(
            {"theta": (("row", "parameter"), self.theta), "context": (("row", "feature"), self.context),
             "target": (("row", "output"), self.target), "group": (("row",), self.group.astype(np.int64))},
            coords={"parameter": list(self.parameter_names), "feature": list(self.context_names),
                    "output": list(self.target_names)},
            attrs={k: (int(v) if isinstance(v, bool) else v if isinstance(v, (int, float, str)) else str(v))
                   for k, v in self.attrs.items()},
        )

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write netCDF atomically (a killed write leaves no half file); returns the path."""
        out = Path(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_suffix(out.suffix + ".tmp")
        self.to_dataset().to_netcdf(tmp)
        tmp.replace(out)
        return out

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Transitions:
        """Read a set written by :meth:`save`; raises :class:`EmbeddingError` naming what is missing."""
        try:
            with xr.open_dataset(path) as ds:
                ds = ds.load()
        except (OSError, ValueError) as exc:
            raise EmbeddingError(f"cannot read transitions from {path}: {exc}") from None
        missing = [v for v in ("theta", "context", "target", "group") if v not in ds]
        if missing:
            raise EmbeddingError(f"{path} lacks {missing}; it was not written by Transitions.save.")
        return cls(ds["theta"].values, ds["context"].values, ds["target"].values, ds["group"].values,
                   tuple(str(v) for v in ds["parameter"].values), tuple(str(v) for v in ds["feature"].values),
                   tuple(str(v) for v in ds["output"].values), dict(ds.attrs))


def push_transitions(space: ParameterSpace, n: int = 20000, *, impulses: tuple[float, float] = (0.5, 1.5),
                     seed: int = 0) -> Transitions:
    """``n`` pushes: θ = (m, μ) uniform in the box, impulse J uniform in ``impulses`` [N s],
    target S = J² / (2 m² μ) [m]; each row is its own group."""
    from physics.push import simulate_push

    if not isinstance(n, (int, np.integer)) or n < 2:
        raise EmbeddingError(f"push_transitions needs n >= 2 rows, got {n!r}.")
    rng = np.random.default_rng(seed)
    theta = space.lower + rng.random((int(n), space.dim)) * (space.upper - space.lower)
    J = rng.uniform(impulses[0], impulses[1], int(n))
    S = simulate_push(theta, [1.0], space=space)[:, 0] * J ** 2          # S is quadratic in J
    return Transitions(theta, J[:, None], S[:, None], np.arange(int(n)), tuple(space.names), ("impulse",),
                       ("displacement",), {"source": "push_transitions", "seed": int(seed)})
