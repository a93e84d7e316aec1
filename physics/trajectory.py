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

Recordings whose clock is regular only up to jitter and dropped frames are put on that clock by
:func:`regular_clock` (``load_trajectory`` does it): timestamps within TIMESTAMP_TOLERANCE of a
tick are snapped to it, ticks without a sample become NaN rows.
"""
from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
import xarray as xr

from physics.errors import ParameterError, TimestampError, TrajectoryFormatError
from physics.geometry import CABLE_NAMES, CABLE_NODES, N_CABLES, N_NODES

__all__ = ["make_trajectory", "validate_trajectory", "save_trajectory", "load_trajectory", "describe_trajectory",
           "regular_clock", "FORMAT_VERSION", "TIMESTAMP_TOLERANCE"]

FORMAT_VERSION = "tensegrid-trajectory-1"
_AXES = ("x", "y", "z")
#: Largest distance of a timestamp from its tick on the regular clock that :func:`regular_clock`
#: snaps, as a fraction of the sample interval Δ. Snapping moves a sample in time by at most
#: 0.25 Δ, which misplaces a node moving at v by at most 0.25 v Δ (2 mm at 1 m/s and 120 Hz);
#: ticks are Δ apart, so which tick a sample belongs to stays unambiguous with a margin of 2.
TIMESTAMP_TOLERANCE = 0.25
#: Relative step spread of a clock taken as uniform as it is (no snapping): what validation accepts.
_UNIFORM = 1e-6
#: Largest drift, as a fraction of Δ, that rounding the fitted rate to whole hertz may add to any tick.
_ROUND_RATE = 0.01
#: The first bytes of a netCDF file: classic (CDF-1, CDF-2, CDF-5) and netCDF-4 (HDF5).
_NETCDF3 = (b"CDF\x01", b"CDF\x02", b"CDF\x05")
_HDF5 = b"\x89HDF\r\n\x1a\n"


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


def _is_uniform(steps: np.ndarray) -> bool:
    """Whether time steps (T - 1,) are equal within _UNIFORM of their mean (1e-9 s at least)."""
    mean = float(steps.mean())
    return bool(np.max(np.abs(steps - mean)) <= _UNIFORM * max(1.0, mean) + 1e-9)


def _validate_time(ds: xr.Dataset, source: str | None) -> None:
    """The ``time`` coordinate: numbers, at least 2, finite, strictly increasing and uniform."""
    if "time" not in ds.coords:
        _fail("missing coordinate 'time' (seconds).", source)
    if ds["time"].dtype.kind not in "fiu":
        _fail(f"'time' must be numbers of seconds, got dtype {ds['time'].dtype}; convert, e.g. "
              "ds['time'] = (ds['time'] - ds['time'][0]) / np.timedelta64(1, 's').", source)
    t = np.asarray(ds["time"].values, dtype=float)
    if t.size < 2:
        _fail(f"needs at least 2 time samples, got {t.size}.", source)
    if not np.all(np.isfinite(t)):
        _fail("'time' contains NaN or infinite values.", source)
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0))
        _fail(f"'time' must increase strictly; it does not at index {i + 1} (t = {t[i]} then {t[i + 1]}). "
              "Sort by time and drop repeated timestamps.", source)
    if not _is_uniform(dt):
        _fail(f"'time' must be uniformly sampled; steps range from {dt.min():.6g} to {dt.max():.6g} s. Put it on "
              "its regular clock with physics.trajectory.regular_clock(ds) (load_trajectory does): jitter within "
              f"{TIMESTAMP_TOLERANCE:.0%} of the interval is snapped, missing timestamps become NaN rows.", source)


def _seconds(ds: xr.Dataset) -> np.ndarray | None:
    """The ``time`` coordinate as floats (T,), or None when it is missing or not numbers (validation says so)."""
    if not isinstance(ds, xr.Dataset) or "time" not in ds.coords or ds["time"].dims != ("time",):
        return None
    if ds["time"].dtype.kind not in "fiu":
        return None
    return np.asarray(ds["time"].values, dtype=float)


def _fit_clock(t: np.ndarray, source: str | None) -> tuple[np.ndarray, float, float]:
    """(ticks (T,), Δ [s], t0 [s]) of the regular clock t_i ≈ t0 + ticks_i Δ through increasing times t (T,).

    A step of about m median steps spans m ticks (m - 1 dropped frames); Δ and t0 are the least-squares
    line through (ticks_i, t_i), fitted again without the samples more than 3 median deviations off it
    (so that one late timestamp does not tilt the clock). Δ is then rounded to whole hertz,
    1 / round(1 / Δ) with t0 refitted, when that moves no tick by more than _ROUND_RATE Δ, so that a
    120 Hz recording gets Δ = 1/120 s exactly.
    Raises TimestampError when more ticks would be missing than samples are present: the median step is
    then not the recording's interval."""
    steps = np.diff(t)
    median = float(np.median(steps))
    spans = np.maximum(np.rint(steps / median), 1.0)
    total = float(spans.sum()) + 1
    if total > 2 * t.size:
        where = f" in {source}" if source else ""
        raise TimestampError(
            f"Invalid trajectory{where}: on a regular clock of the median step {median:.6g} s, {total - t.size:.0f} "
            f"of {total:.0f} ticks would have no sample (more missing than present), so that step is not the "
            "sampling interval; give 'time' in seconds of the capture clock, with NaN rows for dropped frames. "
            "See docs/data-format.md.")
    ticks = np.concatenate([[0], np.cumsum(spans)]).astype(np.int64)
    interval, start = (float(v) for v in np.polyfit(ticks, t, 1))
    deviation = np.abs(t - start - ticks * interval)
    keep = deviation <= 3.0 * np.median(deviation) + 1e-12 * interval
    if 2 <= keep.sum() < keep.size:
        interval, start = (float(v) for v in np.polyfit(ticks[keep], t[keep], 1))
    with np.errstate(over="ignore", divide="ignore"):
        rate = 1.0 / interval
    if np.isfinite(rate) and rate >= 0.5:
        whole = 1.0 / round(rate)
        shifted = float(np.mean(t[keep] - ticks[keep] * whole))
        if np.max(np.abs(ticks * (whole - interval) + (shifted - start))) <= _ROUND_RATE * interval:
            return ticks, whole, shifted
    return ticks, interval, start


def regular_clock(ds: xr.Dataset, *, tolerance: float = TIMESTAMP_TOLERANCE, source: str | None = None
                  ) -> xr.Dataset:
    """``ds`` on its regular clock t_k = t0 + k Δ, k = 0..K: each sample at its tick, NaN rows at ticks without one.

    The clock (Δ, t0 and each sample's tick) is fitted to the timestamps (:func:`_fit_clock`); every
    timestamp must lie within ``tolerance`` Δ of its tick (TIMESTAMP_TOLERANCE by default; below 0.5,
    where a sample would sit as near another tick), else :class:`TimestampError`. Missing samples are
    NaN, never imputed. The attribute ``clock`` says what was done. Returned unchanged: a clock
    already uniform (steps equal within 1e-6), and a time axis that validation refuses for another
    reason (missing, not numbers, not finite and strictly increasing, fewer than 2 samples).
    ``source`` names the file in messages.
    """
    if not 0 <= tolerance < 0.5:
        raise ParameterError(f"tolerance must be a fraction of the interval in [0, 0.5), got {tolerance!r}.")
    t = _seconds(ds)
    if t is None or t.size < 2 or not np.all(np.isfinite(t)):
        return ds
    steps = np.diff(t)
    if np.any(steps <= 0) or _is_uniform(steps):
        return ds
    ticks, interval, start = _fit_clock(t, source)
    deviation = np.abs(t - (start + ticks * interval))
    worst = int(np.argmax(deviation))
    if deviation[worst] > tolerance * interval:
        where = f" in {source}" if source else ""
        raise TimestampError(
            f"Invalid trajectory{where}: timestamp {worst} (t = {t[worst]:.6g} s) lies {deviation[worst]:.3g} s off "
            f"its tick on the regular {1 / interval:.6g} Hz clock, {deviation[worst] / interval:.0%} of the interval "
            f"{interval:.6g} s, and only deviations up to {tolerance:.0%} are snapped; use the capture system's frame "
            "numbers times its frame interval as 'time'. See docs/data-format.md.")
    total = int(ticks[-1]) + 1
    attrs = dict(ds["time"].attrs)
    out = ds.assign_coords(time=ticks).reindex(time=np.arange(total))
    out = out.assign_coords(time=("time", start + np.arange(total) * interval, attrs))
    out.attrs["clock"] = (f"put on the regular {1 / interval:.6g} Hz clock: moved by up to "
                          f"{deviation[worst]:.3g} s ({deviation[worst] / interval:.1%} of the interval; tolerance "
                          f"{tolerance:.0%}), {total - t.size} missing timestamps became NaN rows")
    return out


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
    if not isinstance(units, str) or units not in ("m", "meter", "metre", "meters", "metres"):
        _fail(f"'nodes' must be in metres (units='m'), got units={units!r}; convert, e.g. mm / 1000.", source)
    _validate_time(ds, source)
    for var in ("nodes", "controls", "velocities", "rest_length", "tension"):
        if var in ds and ds[var].dtype.kind not in "fiu":
            _fail(f"{var!r} must hold numbers, got dtype {ds[var].dtype}.", source)
    nodes = np.asarray(ds["nodes"].values, dtype=float)
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


def _is_netcdf(path: Path) -> bool:
    """Whether the file starts as netCDF does: classic ``CDF`` 1, 2 or 5, or netCDF-4's HDF5 signature
    (at byte 0, 512, 1024 or 2048, where HDF5 may put it after a user block)."""
    with path.open("rb") as fh:
        head = fh.read(2048 + len(_HDF5))
    return head[:4] in _NETCDF3 or any(head[at:at + len(_HDF5)] == _HDF5 for at in (0, 512, 1024, 2048))


def _not_netcdf(path: Path) -> TrajectoryFormatError:
    """The error for a file that is no netCDF (a CSV, most often): the convert command that makes one."""
    out = path.with_suffix(".nc") if path.suffix != ".nc" else path.with_name(f"{path.stem}-converted.nc")
    return TrajectoryFormatError(f"{path} is not a netCDF trajectory; convert it first: tensegrid convert {path} "
                                 f"{out} --units m|cm|mm (see docs/data-format.md).")


def load_trajectory(path: str | os.PathLike[str]) -> xr.Dataset:
    """Read a trajectory netCDF file, put it on its regular clock (:func:`regular_clock`) and validate it;
    explain what is wrong with a bad file (one that is no netCDF at all: how to convert it). Times are
    read as the numbers stored (no CF date decoding)."""
    path = Path(path)
    if not path.exists():
        raise TrajectoryFormatError(f"Trajectory file {str(path)!r} does not exist.")
    if path.is_file() and not _is_netcdf(path):
        raise _not_netcdf(path)
    try:
        with xr.open_dataset(path, decode_times=False, decode_timedelta=False) as ds:
            ds = ds.load()
    except Exception as exc:  # netCDF4/xarray raise many types for unreadable files
        raise TrajectoryFormatError(
            f"Cannot read {str(path)!r} as netCDF ({type(exc).__name__}: {exc}). "
            "Write trajectories with physics.save_trajectory or xarray.Dataset.to_netcdf."
        ) from exc
    return validate_trajectory(regular_clock(ds, source=str(path)), source=str(path))


def describe_trajectory(ds: xr.Dataset) -> list[str]:
    """What a trajectory holds and lacks, and what the model does about it, one sentence each."""
    t = np.asarray(ds["time"].values, float)
    nodes = np.asarray(ds["nodes"].values, float)
    lines = [f"{len(t)} samples at {1.0 / (t[1] - t[0]):.4g} Hz over {t[-1] - t[0]:.3g} s"]
    if ds.attrs.get("clock"):
        lines.append(f"timestamps {ds.attrs['clock']}")
    missing = int((~np.isfinite(nodes).all(axis=(1, 2))).sum())
    if missing:
        lines.append(f"{missing} samples with missing (NaN) node positions: skipped, never imputed")
    bad_controls = int((~np.isfinite(ds["controls"].values).all(axis=1)).sum())
    if bad_controls:
        lines.append(f"{bad_controls} samples with missing controls: the last command is held")
    if "velocities" not in ds:
        lines.append("no node velocities: estimated from the positions around each sample (physics.state_estimation)")
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
