"""Marker tables (CSV) to and from the trajectory format (docs/data-format.md), with the frame transform.

One row per sample: a time column, the 36 node coordinates and the 24 commanded rest lengths,
optionally the 24 measured rest lengths. Column names come from patterns (case and surrounding
spaces ignored; physics.column_patterns): ``node_columns`` with ``{node}`` (0..11: rod i joins
nodes 2i and 2i+1) or ``{label}`` (the node's entry of ``labels``) and ``{axis}``/``{AXIS}`` (x, y,
z of the file's frame), ``control_columns`` and ``rest_length_columns`` with ``{cable}`` (the cable
names of physics.geometry, e.g. ``c00_04``) or ``{a}`` and ``{b}``, the labels of the cable's end
nodes in either order. Other columns are ignored; an empty cell is a missing value (NaN). A
missing column is named with the nearest column the file has.

Units: lengths in ``units`` (m, cm or mm; nodes and rest lengths alike), time in ``time_unit``
(s, ms or us). Frame: the file's axes are right-handed with ``up`` (x, y, z, -x, -y or -z)
pointing against gravity; the world frame of the format has z up. The rotation
(:func:`up_rotation`) keeps the file's x axis as world x (its y axis when up is ±x), takes
``up`` as world z and completes the frame right-handed, y_w = z_w × x_w, so for y up
(x, y, z)_file -> (x, -z, y)_world: a proper rotation (determinant +1), never a mirror.

Then the clock is made regular (physics.trajectory.regular_clock: jitter snapped, missing
timestamps become NaN rows) and the Dataset is validated. C3D files are not read: see
docs/data-format.md, "Converting a CSV".
"""
from __future__ import annotations

import difflib
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from physics.column_patterns import layout_from_options
from physics.errors import ImportFormatError
from physics.geometry import CABLE_NAMES, N_NODES
from physics.trajectory import make_trajectory, regular_clock, validate_trajectory

__all__ = ["LENGTH_UNITS", "TIME_UNITS", "UP_AXES", "up_rotation", "from_csv", "to_csv"]

#: Metres per length unit of a file.
LENGTH_UNITS: Mapping[str, float] = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}
#: Seconds per time unit of a file.
TIME_UNITS: Mapping[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
#: The file axes that may point up.
UP_AXES = ("z", "y", "x", "-z", "-y", "-x")
_AXES = ("x", "y", "z")


def up_rotation(up: str) -> np.ndarray:
    """The rotation R (3 x 3) from a right-handed file frame whose axis ``up`` points up to the world
    frame (z up): world = R @ file. Rows: x_w = the file's x (its y when up is ±x), z_w = ``up``,
    y_w = z_w × x_w. Raises :class:`ImportFormatError` for an axis not in UP_AXES."""
    if up not in UP_AXES:
        raise ImportFormatError(f"up must be one of {', '.join(UP_AXES)} (the file axis pointing up), got {up!r}.")
    sign, axis = (-1.0, up[1]) if up.startswith("-") else (1.0, up)
    z_w = sign * np.eye(3)[_AXES.index(axis)]
    x_w = np.eye(3)[1] if axis == "x" else np.eye(3)[0]
    return np.stack([x_w, np.cross(z_w, x_w), z_w])


def _factor(table: Mapping[str, float], value: str, what: str) -> float:
    if value not in table:
        raise ImportFormatError(f"{what} must be one of {', '.join(table)}, got {value!r}.")
    return table[value]


def _shortened(names: Sequence[str], shown: int) -> str:
    """The first ``shown`` of ``names`` (quoted), then how many more."""
    listed = ", ".join(repr(str(n)) for n in names[:shown])
    return listed + (f" and {len(names) - shown} more" if len(names) > shown else "")


def _missing(frame: pd.DataFrame, missing: Sequence[str], what: str, source: str, *, none_found: bool,
             note: str, matched: Sequence[object] = ()) -> str:
    """The one-line message for ``missing`` columns: which, the nearest column of the file to the first
    of them that has one (difflib; columns ``matched`` by other names of the group are no candidates),
    the columns the file has, then ``note``."""
    columns = [str(c) for c in frame.columns]
    taken = {str(c) for c in matched}
    lowered = {c.strip().lower(): c for c in columns if c not in taken}
    near = next(((name, lowered[m[0]]) for name in missing
                 if (m := difflib.get_close_matches(name.strip().lower(), list(lowered), n=1))), None)
    head = (f"no {what} column (expected e.g. {missing[0]!r})" if none_found else
            f"{what} columns missing: {', '.join(missing[:4])}" + (f" and {len(missing) - 4} more"
                                                                   if len(missing) > 4 else ""))
    nearest = f"nearest to {near[0]!r}: {near[1]!r}" if near else "no column of the file is near them"
    return (f"{source}: {head}; {nearest}; the file has {len(columns)} columns: {_shortened(columns, 8)}; "
            f"name the columns as the pattern says or pass another pattern or labels{note} (docs/data-format.md, "
            "'Converting a CSV').")


def _optional(frame: pd.DataFrame, names: Sequence[Sequence[str]], what: str, source: str, *,
              note: str = "") -> np.ndarray | None:
    """The columns ``names`` of ``frame`` as floats (T x len(names)), matched without case and spaces, or
    None when none of them exists; each entry of ``names`` lists the names one column may have (a
    cable's ends in either order). Raises :class:`ImportFormatError` for a partial set, for two
    columns of the file matching one entry and for cells that are not numbers (``note`` ends the
    message of missing columns)."""
    lookup = {str(c).strip().lower(): c for c in frame.columns}
    found: list[object] = []
    for options in names:
        present = [lookup[n.strip().lower()] for n in options if n.strip().lower() in lookup]
        if len(present) > 1:
            raise ImportFormatError(f"{source}: the {what} columns {str(present[0])!r} and {str(present[1])!r} "
                                    "name the same cable (its ends in either order); keep one of them.")
        found.append(present[0] if present else None)
    missing = [options[0] for options, column in zip(names, found, strict=True) if column is None]
    if len(missing) == len(names):
        return None
    if missing:
        raise ImportFormatError(_missing(frame, missing, what, source, none_found=False, note=note, matched=found))
    try:
        return frame[found].apply(pd.to_numeric, errors="raise").to_numpy(dtype=float)
    except (TypeError, ValueError) as exc:
        raise ImportFormatError(f"{source}: a {what} cell is not a number ({exc}); leave missing values "
                                "empty (they become NaN).") from None


def _required(frame: pd.DataFrame, names: Sequence[Sequence[str]], what: str, source: str, *,
              note: str = "") -> np.ndarray:
    """:func:`_optional` for columns that must be there: :class:`ImportFormatError` when none is."""
    found = _optional(frame, names, what, source, note=note)
    if found is None:
        raise ImportFormatError(_missing(frame, [options[0] for options in names], what, source, none_found=True,
                                         note=note))
    return found


def _read(path: Path, delimiter: str) -> pd.DataFrame:
    """The CSV as a DataFrame (lines starting with # skipped); :class:`ImportFormatError` if unreadable."""
    if not path.is_file():
        raise ImportFormatError(f"CSV file {str(path)!r} does not exist.")
    try:
        return pd.read_csv(path, sep=delimiter, comment="#", skipinitialspace=True)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise ImportFormatError(f"Cannot read {str(path)!r} as CSV ({type(exc).__name__}: {exc}); check the "
                                "delimiter.") from None


def from_csv(path: str | os.PathLike[str], *, units: str = "m", up: str = "z", time_unit: str = "s",
             time_column: str = "time", node_columns: str = "node{node}_{axis}", control_columns: str = "{cable}",
             rest_length_columns: str = "rest_{cable}", labels: Sequence[str] | None = None,
             length_reference: str | None = None, delimiter: str = ",") -> xr.Dataset:
    """A trajectory Dataset (docs/data-format.md) from a CSV of markers and controls (module docstring).

    nodes (T x 12 x 3) = R · file coordinates x ``units`` factor [m], R = :func:`up_rotation` (``up``);
    controls and rest lengths (T x 24) x the same factor [m]; time x ``time_unit`` factor [s],
    then put on its regular clock. ``labels`` name nodes 0..11 for the patterns' ``{label}``, ``{a}``
    and ``{b}`` (physics.column_patterns; default the node numbers; kept as the attribute
    ``csv_labels``). ``length_reference`` ("encoder" or "true") is stored as the attribute of that
    name when given. Raises :class:`ImportFormatError` for a layout problem (for the patterns and
    labels before the file is read) and the loader's errors (TimestampError, TrajectoryFormatError)
    for the data.
    """
    layout = layout_from_options(time_column=time_column, node_columns=node_columns,
                                 control_columns=control_columns, rest_length_columns=rest_length_columns,
                                 labels=labels)
    path = Path(path)
    scale = _factor(LENGTH_UNITS, units, "units")
    seconds = _factor(TIME_UNITS, time_unit, "time_unit")
    rotation = up_rotation(up)
    if length_reference not in (None, "encoder", "true"):
        raise ImportFormatError(f"length_reference must be 'encoder' or 'true' (or left out), got "
                                f"{length_reference!r}.")
    frame = _read(path, delimiter)
    source = str(path)
    note = (" (without labels, {label}, {a} and {b} are node numbers)"
            if layout.labels is None and layout.uses_labels() else "")
    time = _required(frame, [(layout.time_column,)], "time", source)
    nodes = _required(frame, [(name,) for name in layout.node_names()], "node", source, note=note)
    controls = _required(frame, layout.control_names(), "control", source, note=note)
    rest = _optional(frame, layout.rest_length_names(), "rest length", source, note=note)
    world = nodes.reshape(-1, N_NODES, 3) @ rotation.T * scale
    attrs: dict[str, object] = {"source": f"tensegrid.physics.importers.from_csv({path.name})", "csv_units": units,
                                "csv_up_axis": up, "csv_time_unit": time_unit}
    if layout.labels is not None:
        attrs["csv_labels"] = ",".join(layout.labels)
    if length_reference is not None:
        attrs["length_reference"] = length_reference
    ds = xr.Dataset(
        {"nodes": (("time", "node", "axis"), world, {"units": "m"}),
         "controls": (("time", "cable"), controls * scale, {"units": "m"})},
        coords={"time": ("time", time[:, 0] * seconds, {"units": "s"}), "node": np.arange(N_NODES),
                "axis": list(_AXES), "cable": list(CABLE_NAMES)}, attrs=attrs)
    if rest is not None:
        ds["rest_length"] = (("time", "cable"), rest * scale, {"units": "m"})
    ds = regular_clock(ds, source=source)
    ds = validate_trajectory(ds, source=source)
    return make_trajectory(ds["time"].values, ds["nodes"].values, ds["controls"].values,
                           rest_length=ds["rest_length"].values if "rest_length" in ds else None, attrs=ds.attrs)


def to_csv(ds: xr.Dataset, path: str | os.PathLike[str], *, units: str = "m", up: str = "z", time_unit: str = "s",
           time_column: str = "time", node_columns: str = "node{node}_{axis}", control_columns: str = "{cable}",
           rest_length_columns: str = "rest_{cable}", labels: Sequence[str] | None = None) -> Path:
    """Write a trajectory as the CSV :func:`from_csv` reads with the same options (its inverse: file
    coordinates = R^T · nodes / units factor; a cable's ``{a}``/``{b}`` in CABLE_NODES order); NaN as
    empty cells, full float precision. Returns the path."""
    layout = layout_from_options(time_column=time_column, node_columns=node_columns,
                                 control_columns=control_columns, rest_length_columns=rest_length_columns,
                                 labels=labels)
    ds = validate_trajectory(ds)
    scale = _factor(LENGTH_UNITS, units, "units")
    seconds = _factor(TIME_UNITS, time_unit, "time_unit")
    nodes = np.asarray(ds["nodes"].values, float) @ up_rotation(up) / scale
    columns: dict[str, np.ndarray] = {layout.time_column: np.asarray(ds["time"].values, float) / seconds}
    for name, values in zip(layout.node_names(), nodes.reshape(len(nodes), 3 * N_NODES).T, strict=True):
        columns[name] = values
    variables = [("controls", layout.control_names())]
    if "rest_length" in ds:
        variables.append(("rest_length", layout.rest_length_names()))
    for var, names in variables:
        values = np.asarray(ds[var].transpose("time", "cable").values, float) / scale
        for c, options in enumerate(names):
            columns[options[0]] = values[:, c]
    out = Path(path)
    pd.DataFrame(columns).to_csv(out, index=False, float_format="%.17g")
    return out
