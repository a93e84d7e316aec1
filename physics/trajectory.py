"""Trajectories as ``xarray.Dataset``: build, validate, save and load (netCDF).

Format (docs/data-format.md):

- ``nodes`` (time, node, axis): world positions of the 12 rod endpoints [m], z up;
- ``controls`` (time, cable): commanded target rest lengths [m] (encoder readings), held from
  one sample to the next;
- optional ``velocities`` (time, node, axis): node velocities [m/s] if the recording has them;
- optional ``rest_length`` (time, cable): measured rest lengths [m] (motor encoders);
- optional ``tension`` (time, cable) [N], ``theta`` (parameter) the parameters that made it;
- coordinates ``time`` [s] (uniform, increasing), ``node`` 0..11, ``axis`` x/y/z, ``cable``
  names with ``end_a``/``end_b`` node indices; missing samples are NaN.
"""
from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
import xarray as xr

from physics.errors import TrajectoryFormatError
from physics.geometry import CABLE_NAMES, CABLE_NODES, N_CABLES, N_NODES

__all__ = ["make_trajectory", "validate_trajectory", "save_trajectory", "load_trajectory", "describe_trajectory",
           "FORMAT_VERSION"]

FORMAT_VERSION = "tensegrid-trajectory-1"
_AXES = ("x", "y", "z")


def _variable(dims: tuple[str, ...], values: np.ndarray, units: str, long_name: str) -> tuple:
    """One data variable of a trajectory Dataset: (dims, float values, attributes)."""
    return dims, np.asarray(values, float), {"units": units, "long_name": long_name}


def make_trajectory(time: np.ndarray, nodes: np.ndarray, controls: np.ndarray, *,
                    velocities: np.ndarray | None = None, rest_length: np.ndarray | None = None,
                    tension: np.ndarray | None = None,
                    theta: np.ndarray | None = None, parameter_names: Iterable[str] | None = None,
                    attrs: Mapping[str, object] | None = None) -> xr.Dataset:
    """Assemble a validated trajectory Dataset.

    time (T,) [s]; nodes, velocities (T x 12 x 3) [m], [m/s]; controls, rest_length, tension (T x 24).
    """
    nodal, cable = ("time", "node", "axis"), ("time", "cable")
    data: dict[str, tuple] = {
        "nodes": _variable(nodal, nodes, "m", "rod endpoint positions"),
        "controls": _variable(cable, controls, "m", "commanded target rest lengths"),
    }
    if velocities is not None:
        data["velocities"] = _variable(nodal, velocities, "m/s", "rod endpoint velocities")
    if rest_length is not None:
        data["rest_length"] = _variable(cable, rest_length, "m", "measured rest lengths")
    if tension is not None:
        data["tension"] = _variable(cable, tension, "N", "cable tensions")
    coords = {
        "time": ("time", np.asarray(time, float), {"units": "s"}),
        "node": np.arange(N_NODES),
        "axis": list(_AXES),
        "cable": list(CABLE_NAMES),
        "end_a": ("cable", CABLE_NODES[:, 0].copy()),
        "end_b": ("cable", CABLE_NODES[:, 1].copy()),
    }
    if theta is not None:
        names = list(parameter_names or [])
        data["theta"] = (("parameter",), np.asarray(theta, float), {"long_name": "parameters that generated the data"})
        coords["parameter"] = names
    ds = xr.Dataset(data, coords=coords, attrs={"format": FORMAT_VERSION, "robot": "SUPERball T6", **dict(attrs or {})})
    return validate_trajectory(ds)


def _fail(msg: str, source: str | None) -> None:
    where = f" in {source}" if source else ""
    raise TrajectoryFormatError(f"Invalid trajectory{where}: {msg} See docs/data-format.md.")


def validate_trajectory(ds: xr.Dataset, *, source: str | None = None) -> xr.Dataset:
    """Check a trajectory against the format; return it (with ``nodes`` transposed to time, node, axis).

    Raises :class:`TrajectoryFormatError` naming what is wrong and how to fix it.
    """
    if not isinstance(ds, xr.Dataset):
        _fail(f"expected an xarray.Dataset, got {type(ds).__name__}.", source)
    for var in ("nodes", "controls"):
        if var not in ds.data_vars:
            _fail(f"missing variable {var!r}; variables present: {sorted(map(str, ds.data_vars))}.", source)
    if set(ds["nodes"].dims) != {"time", "node", "axis"}:
        _fail(f"'nodes' must have dims (time, node, axis), got {ds['nodes'].dims}.", source)
    if "velocities" in ds and set(ds["velocities"].dims) != {"time", "node", "axis"}:
        _fail(f"'velocities' must have dims (time, node, axis), got {ds['velocities'].dims}.", source)
    ds = ds.transpose("time", "node", "axis", ...)
    for var in ("controls", "rest_length", "tension"):
        if var in ds and set(ds[var].dims) != {"time", "cable"}:
            _fail(f"{var!r} must have dims (time, cable), got {ds[var].dims}.", source)
    if ds.sizes["node"] != N_NODES:
        _fail(f"'node' must have {N_NODES} entries (rod endpoints), got {ds.sizes['node']}.", source)
    if ds.sizes["axis"] != 3:
        _fail(f"'axis' must have 3 entries (x, y, z), got {ds.sizes['axis']}.", source)
    if ds.sizes["cable"] != N_CABLES:
        _fail(f"'cable' must have {N_CABLES} entries, got {ds.sizes['cable']}.", source)
    if "end_a" in ds.coords and "end_b" in ds.coords:
        ends = np.stack([ds["end_a"].values, ds["end_b"].values], axis=1)
        if not np.array_equal(np.sort(ends, axis=1), np.sort(CABLE_NODES, axis=1)):
            _fail("cable end_a/end_b do not match the T6 cable layout (docs/data-format.md lists it); "
                  "reorder the cables to that layout.", source)
    units = ds["nodes"].attrs.get("units", "m")
    if units not in ("m", "meter", "metre", "meters", "metres"):
        _fail(f"'nodes' must be in metres (units='m'), got units={units!r}; convert, e.g. mm / 1000.", source)
    if "time" not in ds.coords:
        _fail("missing coordinate 'time' (seconds).", source)
    t = np.asarray(ds["time"].values, dtype=float)
    if t.size < 2:
        _fail(f"needs at least 2 time samples, got {t.size}.", source)
    if not np.all(np.isfinite(t)):
        _fail("'time' contains NaN or infinite values.", source)
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0))
        _fail(f"'time' must increase strictly; it does not at index {i + 1} (t = {t[i]} then {t[i + 1]}). "
              "Sort by time.", source)
    if np.max(np.abs(dt - dt.mean())) > 1e-6 * max(1.0, dt.mean()) + 1e-9:
        _fail(f"'time' must be uniformly sampled; steps range from {dt.min():.6g} to {dt.max():.6g} s. "
              "Resample to a uniform rate (e.g. ds.interp(time=...)).", source)
    nodes = ds["nodes"].values
    if np.all(np.isnan(nodes)):
        _fail("'nodes' holds no finite sample.", source)
    if np.any(np.isinf(nodes)):
        _fail("'nodes' contains infinite values; mark missing samples as NaN instead.", source)
    return ds


def save_trajectory(ds: xr.Dataset, path: str | os.PathLike[str]) -> Path:
    """Write a validated trajectory to netCDF (``.nc``); returns the path."""
    ds = validate_trajectory(ds)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(path)
    return path


def load_trajectory(path: str | os.PathLike[str]) -> xr.Dataset:
    """Read and validate a trajectory netCDF file; explain what is wrong with a bad file."""
    path = Path(path)
    if not path.exists():
        raise TrajectoryFormatError(f"Trajectory file {str(path)!r} does not exist.")
    try:
        with xr.open_dataset(path) as ds:
            ds = ds.load()
    except Exception as exc:  # netCDF4/xarray raise many types for unreadable files
        raise TrajectoryFormatError(
            f"Cannot read {str(path)!r} as netCDF ({type(exc).__name__}: {exc}). "
            "Write trajectories with physics.save_trajectory or xarray.Dataset.to_netcdf."
        ) from exc
    return validate_trajectory(ds, source=str(path))


def describe_trajectory(ds: xr.Dataset) -> list[str]:
    """What a trajectory holds and lacks, and what the model does about it, one sentence each."""
    t = np.asarray(ds["time"].values, float)
    nodes = np.asarray(ds["nodes"].values, float)
    lines = [f"{len(t)} samples at {1.0 / (t[1] - t[0]):.4g} Hz over {t[-1] - t[0]:.3g} s"]
    missing = int((~np.isfinite(nodes).all(axis=(1, 2))).sum())
    if missing:
        lines.append(f"{missing} samples with missing (NaN) node positions: skipped, never imputed")
    bad_controls = int((~np.isfinite(ds["controls"].values).all(axis=1)).sum())
    if bad_controls:
        lines.append(f"{bad_controls} samples with missing controls: the last command is held")
    if "velocities" not in ds:
        lines.append("no node velocities: estimated from past positions (backward differences)")
    if "rest_length" not in ds:
        lines.append("no rest-length readings: the actuator state is reconstructed with the model's actuator")
    reference = ds.attrs.get("length_reference")
    if reference is None:
        lines.append("attribute length_reference absent: controls taken as encoder readings zeroed at the "
                     "nominal design")
    else:
        kind = "true rest lengths" if reference == "true" else "encoder readings"
        lines.append(f"controls and rest lengths are {kind}")
    return lines
