"""The serial form of a belief's parts: values as they come back from JSON, and the parameter space
as xarray variables over ``parameter`` (every field of every :class:`physics.parameters.Parameter`,
so a loaded belief has the box, units and flags it was made with)."""
from __future__ import annotations

import dataclasses
import json
import typing
from typing import Any

import numpy as np
import xarray as xr

from belief.errors import BeliefError
from physics.parameters import Parameter, ParameterSpace

__all__ = ["FIELD_VARS", "jsonable", "short", "space_variables", "space_from_dataset"]

#: Parameter fields stored under another variable name (``name`` and ``unit`` are coordinates)
FIELD_VARS = {"name": "parameter", "unit": "unit", "lower": "lower_bound", "upper": "upper_bound"}


def jsonable(value: Any, name: str) -> Any:
    """``value`` as it comes back from JSON (numpy scalars and arrays become numbers and lists)."""
    def default(v: Any) -> Any:
        if isinstance(v, (np.ndarray, np.generic)):
            return v.tolist()
        raise TypeError(f"{type(v).__name__} is not JSON-able")

    try:
        return json.loads(json.dumps(value, default=default))
    except (TypeError, ValueError) as exc:
        raise BeliefError(f"{name} must be JSON-able (numbers, strings, lists, dicts with string keys), got "
                          f"{short(value)} ({exc}); convert the offending values first.") from None


def short(value: Any, limit: int = 80) -> str:
    """repr(value), cut to ``limit`` characters for an error message."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _field_kinds() -> dict[str, Any]:
    """Parameter field -> its type (str, float, bool or another, stored as JSON)."""
    hints = typing.get_type_hints(Parameter)
    return {f.name: hints.get(f.name, object) for f in dataclasses.fields(Parameter)}


def space_variables(space: ParameterSpace) -> tuple[dict[str, Any], dict[str, Any]]:
    """(coordinates, data variables) over ``parameter`` holding every field of every Parameter."""
    coords: dict[str, Any] = {"parameter": list(space.names), "unit": ("parameter", list(space.units))}
    data: dict[str, Any] = {}
    for name, kind in _field_kinds().items():
        if name in ("name", "unit"):
            continue
        values = [getattr(q, name) for q in space.parameters]
        if kind is bool:
            arr = np.array(values, dtype=np.int8)
        elif kind in (int, float):
            arr = np.array(values, dtype=float)
        elif kind is str:
            arr = np.array(values, dtype=object)
        else:
            arr = np.array([json.dumps(jsonable(v, f"Parameter.{name}")) for v in values], dtype=object)
        data[FIELD_VARS.get(name, name)] = ("parameter", arr)
    return coords, data


def space_from_dataset(ds: xr.Dataset) -> ParameterSpace:
    """The ParameterSpace stored by :func:`space_variables` (fields absent from the file take their defaults)."""
    columns: dict[str, list[Any]] = {}
    for name, kind in _field_kinds().items():
        var = FIELD_VARS.get(name, name)
        if var not in ds.variables:
            continue
        raw = ds[var].values.tolist()
        convert = {bool: bool, float: float, int: int, str: str}.get(kind, json.loads)
        columns[name] = [convert(v) for v in raw]
    try:
        n = len(columns["name"])
        return ParameterSpace(tuple(Parameter(**{k: v[i] for k, v in columns.items()}) for i in range(n)))
    except (KeyError, TypeError, ValueError) as exc:
        raise BeliefError(f"the belief Dataset's parameter space cannot be rebuilt ({exc}); "
                          "re-save the belief.") from None
