"""The best θ of an identification, read from the ``result.nc`` that ``tensegrid identify`` writes.

The file is netCDF-4; its root group holds what another command needs to run the identified robot
(the groups ``belief`` and ``history`` hold the posterior and the evaluations, read by belief):

- ``best_theta`` (parameter): θ of the smallest error evaluated [SI], the coordinate ``parameter``
  naming each value; parameters the user fixed (``--fix``) are not in it;
- attribute ``format``: ``tensegrid.identification/N``;
- attribute ``config`` (JSON): ``fixed`` maps the fixed parameters to their values and ``effects``
  lists the configurations of the effects the identified model carried (physics.effects).

Physics reads the file as plain netCDF so that it need not import belief (which writes it).
"""
from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import xarray as xr

from physics.effects import Effect, effect_from_config, model_space
from physics.errors import ParameterError

__all__ = ["IdentifiedTheta", "read_identified_theta", "RESULT_FORMAT"]

#: The ``format`` attribute of an identification result, up to its version number.
RESULT_FORMAT = "tensegrid.identification/"


@dataclass(frozen=True)
class IdentifiedTheta:
    """The best θ of an identification: ``values`` by name [SI] (the fixed parameters included),
    ``effects`` the identified model carried, ``path`` the file they were read from."""

    path: str
    values: Mapping[str, float]
    effects: tuple[Effect, ...]

    def __post_init__(self) -> None:
        bad = sorted(name for name, value in self.values.items() if not np.isfinite(value))
        if bad:
            raise ParameterError(f"the result file {self.path!r} holds non-finite best θ values for {bad}; "
                                 "re-run the identification.")
        model_space(self.effects)       # effects listed twice, or whose parameters collide, are refused here


def _open_root(path: str) -> xr.Dataset:
    """The root group of ``path``, loaded; ParameterError for a missing file or one that is no netCDF."""
    if not os.path.isfile(path):
        raise ParameterError(f"no result file at {path!r}; pass the result.nc that tensegrid identify wrote.")
    try:
        with xr.open_dataset(path, engine="netcdf4", decode_times=False) as root:
            return root.load()
    except (OSError, ValueError) as exc:
        raise ParameterError(f"{path!r} is not a netCDF file ({exc}); pass the result.nc that tensegrid identify "
                             "wrote.") from None


def _config(root: xr.Dataset, path: str) -> dict:
    """The run's configuration (the root's JSON attribute ``config``), {} when absent."""
    text = root.attrs.get("config", "{}")
    try:
        config = json.loads(text)
    except (TypeError, json.JSONDecodeError):
        config = None
    if not isinstance(config, dict):
        raise ParameterError(f"the result file {path!r} has a 'config' attribute that is not a JSON object; "
                             "re-run the identification.")
    return config


def read_identified_theta(path: str | os.PathLike[str]) -> IdentifiedTheta:
    """The best θ, the fixed values and the effects of the result file ``path`` (module docstring).

    Raises :class:`ParameterError` (one line, naming the file) for a missing file, one that is no
    netCDF, a trajectory or another tensegrid file, and a result without a best θ by name."""
    path = os.fspath(path)
    root = _open_root(path)
    found = root.attrs.get("format")
    if not (isinstance(found, str) and found.startswith(RESULT_FORMAT)):
        hint = ("it is a trajectory (replay it with --replay)" if "nodes" in root.data_vars
                else f"its format is {found!r}")
        raise ParameterError(f"{path!r} is not an identification result ({hint}); pass the result.nc that "
                             "tensegrid identify wrote.")
    best = root.data_vars.get("best_theta")
    if best is None or best.dims != ("parameter",) or "parameter" not in best.coords:
        raise ParameterError(f"the result file {path!r} has no best θ by parameter name ('best_theta' over "
                             "'parameter'); re-run the identification.")
    values = {str(name): float(value) for name, value in zip(best["parameter"].values, best.values, strict=True)}
    config = _config(root, path)
    fixed = config.get("fixed") or {}
    configs = config.get("effects") or []
    if not isinstance(fixed, dict) or not isinstance(configs, list) or not all(isinstance(c, dict) for c in configs):
        raise ParameterError(f"the result file {path!r} records its fixed values or effects in an unknown form; "
                             "re-run the identification.")
    values.update({str(name): float(value) for name, value in fixed.items()})
    return IdentifiedTheta(path=path, values=values, effects=tuple(effect_from_config(c) for c in configs))
