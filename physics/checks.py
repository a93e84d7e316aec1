"""What a trajectory file looks like against the data format (docs/data-format.md) and the robot.

:func:`check_trajectory` reads a Dataset as it is and returns a :class:`DataReport` of typed
:class:`Finding` s, each with what is wrong and the fix: units from the rod lengths and from the
sampling interval, the up axis and the floor from the resting robot (physics.ground), node labels
from rod rigidity and cable lengths (physics.labels), missing samples and jumps, the controls'
units, range and meaning, and whether the encoders' readings are there. Severity ``error`` makes
identification meaningless (wrong units, wrong up axis, swapped ends); ``warning`` biases or
weakens it; ``info`` describes the file.

Lengths and times found in another unit (millimetres, milliseconds) are converted before the
later checks, so one mistake gives one error. :func:`require_rods_in_box` holds an identification's
prior box to the rod length the markers measure. The loader (physics.trajectory) raises nothing for
what only these checks see.
"""
from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
import xarray as xr

from physics.checks_robot import LENGTH_UNITS, check_controls, check_ground, check_rod_labels
from physics.errors import ParameterError, TrajectoryFormatError
from physics.findings import DataCheckError, DataReport, Finding
from physics.geometry import CABLE_NODES, N_NODES, ROD_NODES, node_positions
from physics.parameters import ParameterSpace

__all__ = ["Finding", "DataReport", "DataCheckError", "check_trajectory", "check_file", "require_clean",
           "require_rods_in_box", "rest_length_range", "check_time", "check_length_units", "check_dropouts",
           "check_jumps", "check_readings"]

#: Plausible sampling intervals of a recording [s] (10 Hz to 5 kHz).
INTERVAL_RANGE = (2e-4, 0.1)
#: Unit factors tried for times: (seconds per unit, name).
TIME_UNITS = ((1.0, "seconds"), (1e-3, "milliseconds"), (1e-6, "microseconds"))
#: Relative deviation of a sample interval from the median that the loader accepts.
JITTER_TOLERANCE = 1e-6
#: Fastest plausible node speed between two samples [m/s].
MAX_NODE_SPEED = 10.0
#: A sample farther than max(SPIKE_MIN, SPIKE_ACCELERATION dt² / 2) [m] from the midpoint of its two
#: neighbours is a glitch: a flopping T6's nodes stay within about 2 mm of it at 100 Hz.
SPIKE_MIN = 0.01
SPIKE_ACCELERATION = 200.0
#: How far [m] the rods' measured length may lie outside the rod_length box before an identification
#: refuses the box: markers are noisy by a few mm, and the medians over samples and rods shrink that.
ROD_LENGTH_TOLERANCE = 0.005


def _t6_box(space: ParameterSpace, name: str) -> tuple[float, float, float]:
    """(nominal, lower, upper) of a T6 parameter from ``space``, or from the default T6 box if it lacks it."""
    source = space if name in space.names else ParameterSpace.t6()
    p = source[name]
    return p.nominal, p.lower, p.upper


def rest_length_range(space: ParameterSpace) -> tuple[float, float]:
    """Build rest lengths L0 = L_build - pretension / k over the box [m]: the shortest at the box's
    smallest geometry and largest pretension / k, the longest at the opposite corner."""
    geometry = [(_t6_box(space, "rod_length")[i], _t6_box(space, "rod_space")[j]) for i in (1, 2) for j in (1, 2)]
    lengths = np.concatenate([np.linalg.norm(np.diff(node_positions(r, s)[CABLE_NODES], axis=1)[:, 0], axis=1)
                              for r, s in geometry])
    _, pt_lo, pt_hi = _t6_box(space, "pretension")
    _, k_lo, k_hi = _t6_box(space, "stiffnessActive")
    return float(lengths.min() - pt_hi / k_lo), float(lengths.max() - pt_lo / k_hi)


def _structure(ds: xr.Dataset) -> str | None:
    """What keeps the checks from reading ``ds`` at all, or None."""
    if not isinstance(ds, xr.Dataset):
        return f"expected an xarray.Dataset, got {type(ds).__name__}."
    if "nodes" not in ds.data_vars or set(ds["nodes"].dims) != {"time", "node", "axis"}:
        return "needs a variable 'nodes' with dims (time, node, axis)."
    if ds.sizes["node"] != N_NODES or ds.sizes["axis"] != 3:
        return f"'nodes' must be {N_NODES} nodes x 3 axes, got {ds.sizes['node']} x {ds.sizes['axis']}."
    if "time" not in ds.coords or ds.sizes["time"] < 2:
        return "needs a coordinate 'time' with at least 2 samples."
    return None


def check_time(time: np.ndarray, declared: str | None) -> tuple[list[Finding], float, float]:
    """Time units from the median sample interval Δ (seconds if Δ lies in INTERVAL_RANGE, else the
    unit of TIME_UNITS that brings it there), jitter (max |Δ_i - Δ| against JITTER_TOLERANCE Δ) and
    gaps (Δ_i > 1.5 Δ). time (T,); returns (findings, seconds per unit, Δ [s])."""
    out: list[Finding] = []
    steps = np.diff(time)
    if not np.all(np.isfinite(time)) or np.any(steps <= 0):
        return [Finding("time-order", "error", "'time' is not finite and strictly increasing.",
                        "sort by time and drop repeated or NaN timestamps.")], 1.0, float("nan")
    median = float(np.median(steps))
    said = f" (the file declares units={declared!r})" if declared else ""
    scale = next((f for f, _ in TIME_UNITS if INTERVAL_RANGE[0] <= median * f <= INTERVAL_RANGE[1]), None)
    if scale is None:
        out.append(Finding("time-rate", "warning", f"the sample interval {median:.4g} s ({1 / median:.3g} Hz){said} "
                           "is outside 10 Hz-5 kHz.", "give 'time' in seconds at the recording's rate."))
        scale = 1.0
    elif scale != 1.0:
        name = dict(TIME_UNITS)[scale]
        out.append(Finding("time-units", "error", f"the sample interval is {median:.4g} time units{said}: "
                           f"{1 / median:.3g} Hz in seconds, {1 / (median * scale):.4g} Hz in {name}; time "
                           f"looks like {name}.", f"convert to seconds: ds['time'] = ds['time'] * {scale:g}."))
    dt = median * scale
    regular = steps[steps <= 1.5 * median]
    deviation = float(np.max(np.abs(regular - median))) * scale if regular.size else 0.0
    gaps = int(np.sum(steps > 1.5 * median))
    span = (time[-1] - time[0]) * scale
    out.append(Finding("sampling", "info", f"{len(time)} samples at {1 / dt:.4g} Hz over {span:.4g} s "
                       f"(median interval {dt * 1e3:.4g} ms, max deviation {deviation * 1e3:.3g} ms)."))
    if deviation > JITTER_TOLERANCE * dt:
        out.append(Finding("time-jitter", "warning", f"sample intervals deviate from {dt * 1e3:.4g} ms by up to "
                           f"{deviation * 1e3:.3g} ms ({100 * deviation / dt:.2g} %); the model needs uniform "
                           f"sampling (relative tolerance {JITTER_TOLERANCE:g}).",
                           "round the timestamps to the nominal rate or resample (ds.interp(time=...))."))
    if gaps:
        out.append(Finding("time-gaps", "warning", f"{gaps} intervals are longer than 1.5 x {dt * 1e3:.4g} ms "
                           "(dropped frames).", "insert NaN rows at the missing times (ds.reindex(time=...)); "
                           "missing samples are NaN, never imputed."))
    return out, scale, dt


def check_length_units(rods: np.ndarray, space: ParameterSpace, declared: str | None
                       ) -> tuple[list[Finding], float, float]:
    """Length units from the median of the six median rod lengths (rods (6,) in file units) against
    the rod_length box [lo, hi]: the unit of LENGTH_UNITS that brings it into [lo / 1.5, 1.5 hi].
    Returns (findings, metres per unit, median rod length [m])."""
    _, lo, hi = _t6_box(space, "rod_length")
    median = float(np.nanmedian(rods)) if np.isfinite(rods).any() else float("nan")
    said = f" (the file declares units={declared!r})" if declared else ""
    scale = next((f for f, _ in LENGTH_UNITS if lo / 1.5 <= median * f <= 1.5 * hi), None)
    if scale is None:
        return [Finding("length-units", "error", f"rods measure {median:.4g} length units{said}, in no unit near "
                        f"the rod_length box [{lo:.3g}, {hi:.3g}] m.", "give 'nodes' in metres, and check that "
                        "node 2i and 2i+1 are the two ends of rod i (docs/data-format.md).")], 1.0, median
    length = median * scale
    if scale != 1.0:
        name = dict(LENGTH_UNITS)[scale]
        out = [Finding("length-units", "error", f"rods measure {median:.4g} length units{said}: {length:.3f} m if "
                       f"the nodes are in {name}.", f"convert to metres: ds['nodes'] = ds['nodes'] * {scale:g} "
                       "(with attrs units='m').")]
    else:
        out = []
    out.append(Finding("rod-length", "info", f"rods measure {length:.3f} m (median; box [{lo:.3f}, {hi:.3f}] m)."))
    if not lo <= length <= hi:
        out.append(Finding("rod-length-box", "warning", f"the rods' {length:.3f} m lie outside the rod_length box "
                           f"[{lo:.3f}, {hi:.3f}] m.", "widen the box (ParameterSpace.t6(bounds={'rod_length': "
                           "(lo, hi)}) or nominal=...) so the identification can reach it."))
    return out, scale, length


def check_dropouts(nodes: np.ndarray, time: np.ndarray) -> list[Finding]:
    """Samples with a NaN node coordinate (nodes T x 12 x 3, time T [s]): how many, how many are whole
    frames lost (every node missing, as a dropped frame or a missing timestamp gives) and how many miss
    only some nodes, the longest run of consecutive ones and, when some nodes drop out alone, the node
    missing most often (in a whole lost frame every node is missing alike)."""
    missing = ~np.isfinite(nodes).all(axis=(1, 2))
    count = int(missing.sum())
    if not count:
        return []
    edges = np.diff(np.concatenate([[0], missing.astype(int), [0]]))
    longest = int(np.max(np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)))
    partial = int(np.sum(missing & np.isfinite(nodes).any(axis=(1, 2))))
    per_node = (~np.isfinite(nodes).all(axis=2) & np.isfinite(nodes).any(axis=(1, 2))[:, None]).sum(axis=0)
    dt = float(np.median(np.diff(time)))
    whole = count - partial
    most = (f"; node {int(np.argmax(per_node))} is missing most often ({int(per_node.max())} of those samples)"
            if partial else "")
    frames = (f"{_count(whole, 'frame')} missing entirely (all nodes NaN), {_count(partial, 'frame')} with only "
              "some nodes missing")
    return [Finding("dropouts", "warning", f"{count} of {len(time)} samples ({100 * count / len(time):.1f} %) miss "
                    f"node positions: {frames}; longest gap {_count(longest, 'sample')} ({longest * dt:.3g} s){most}.",
                    "nothing to impute: NaN samples are skipped, never interpolated; a gap removes every prediction "
                    "that spans it, so re-record if gaps cover the motion.")]


def _count(n: int, noun: str) -> str:
    """"1 frame", "2 frames"."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def check_jumps(nodes: np.ndarray, time: np.ndarray) -> list[Finding]:
    """Marker glitches: node steps faster than MAX_NODE_SPEED between consecutive samples (speed
    |x_i+1 - x_i| / (t_i+1 - t_i) [m/s]), and spikes, samples off the midpoint of their neighbours by
    more than the SPIKE_MIN / SPIKE_ACCELERATION limit; nodes (T x 12 x 3) [m], time (T,) [s]; NaN
    samples are not compared."""
    steps = np.linalg.norm(np.diff(nodes, axis=0), axis=-1)
    speed = np.nan_to_num(steps / np.diff(time)[:, None], nan=0.0)
    fast = speed > MAX_NODE_SPEED
    dt = float(np.median(np.diff(time))) if len(time) > 1 else 0.0
    limit = max(SPIKE_MIN, 0.5 * SPIKE_ACCELERATION * dt**2)
    off = np.nan_to_num(np.linalg.norm(nodes[1:-1] - 0.5 * (nodes[:-2] + nodes[2:]), axis=-1), nan=0.0)
    spikes = off > limit
    if not fast.any() and not spikes.any():
        return []
    if fast.any():
        i, k = np.unravel_index(int(np.argmax(np.where(fast, speed, -np.inf))), speed.shape)
        worst = (f"the fastest: node {k} between t = {time[i]:.3f} and {time[i + 1]:.3f} s, {speed[i, k]:.3g} m/s "
                 f"({steps[i, k]:.3f} m in one sample)")
    else:
        i, k = np.unravel_index(int(np.argmax(off)), off.shape)
        worst = f"the largest: node {k} at t = {time[i + 1]:.3f} s, {1e3 * off[i, k]:.0f} mm off its neighbours"
    return [Finding("jumps", "warning", f"{int(fast.sum())} node steps faster than {MAX_NODE_SPEED:g} m/s and "
                    f"{int(spikes.sum())} samples more than {1e3 * limit:.0f} mm off the midpoint of their "
                    f"neighbours; {worst}.",
                    "a marker glitched or was swapped there: set those samples to NaN (they are then skipped).")]


def check_readings(ds: xr.Dataset) -> list[Finding]:
    """An info finding when the file has no encoder readings (``rest_length`` absent or never
    finite): with them the actuator's law (delay, rate limit, lag, tension limit, mis-zeroed
    encoders) is measured from commands -> readings alone (physics.actuator_readings), before any
    dynamics; without them the model's actuator is run along the observed cable lengths instead."""
    if "rest_length" in ds.data_vars and np.isfinite(np.asarray(ds["rest_length"].values, dtype=float)).any():
        return []
    what = "no 'rest_length'" if "rest_length" not in ds.data_vars else "'rest_length' has no finite value"
    return [Finding("rest-length-missing", "info", f"{what} (the motors' encoder readings): the actuator's law "
                    "is left to the dynamics, with the model's actuator run along the observed cable lengths.",
                    "record the encoder readings as 'rest_length' (time, cable) [m] (docs/data-format.md): with "
                    "them the actuator (delay, rate limit, lag, tension limit, encoder offsets) is measured "
                    "directly from commands -> readings (physics.actuator_readings.identify_actuator).")]


_RANK = {"error": 0, "warning": 1, "info": 2}


def check_trajectory(ds: xr.Dataset, space: ParameterSpace | None = None, *, source: str | None = None) -> DataReport:
    """Run every check on a trajectory Dataset (docs/data-format.md) against the box of ``space``
    (default ``ParameterSpace.t6()``); findings sorted errors first. The Dataset need not pass the
    loader's validation: only 'nodes' (time, node, axis) 12 x 3 and a 'time' coordinate are needed."""
    space = space or ParameterSpace.t6()
    problem = _structure(ds)
    if problem:
        return DataReport((Finding("format", "error", problem, "see docs/data-format.md."),), source=source)
    ds = ds.transpose("time", "node", "axis", ...)
    time_raw = np.asarray(ds["time"].values, dtype=float)
    nodes_raw = np.asarray(ds["nodes"].values, dtype=float)
    findings, time_scale, interval = check_time(time_raw, ds["time"].attrs.get("units"))
    if "time-order" in (f.code for f in findings):
        return DataReport(tuple(findings), source=source)
    with np.errstate(invalid="ignore"):
        rods = np.linalg.norm(nodes_raw[:, ROD_NODES[:, 1]] - nodes_raw[:, ROD_NODES[:, 0]], axis=-1)
    per_rod = np.array([np.nanmedian(r) if np.isfinite(r).any() else np.nan for r in rods.T])
    units, length_scale, rod = check_length_units(per_rod, space, ds["nodes"].attrs.get("units"))
    findings += units
    time, nodes = time_raw * time_scale, nodes_raw * length_scale
    controls = (np.asarray(ds["controls"].values, dtype=float)
                if "controls" in ds and ds["controls"].dims == ("time", "cable") else None)
    plane = None
    if "rod-length" in (f.code for f in units):           # lengths are known in metres
        findings += check_rod_labels(nodes, rod)
        ground, plane = check_ground(nodes, time, controls, _t6_box(space, "radius")[0])
        findings += ground + check_jumps(nodes, time)
    findings += check_dropouts(nodes, time)
    slack = _t6_box(space, "pretension")[0] / _t6_box(space, "stiffnessActive")[0]
    findings += check_controls(controls, ds.attrs.get("length_reference"), rest_length_range(space), nodes, time, slack)
    findings += check_readings(ds)
    ordered = tuple(sorted(findings, key=lambda f: _RANK[f.severity]))
    return DataReport(ordered, source=source, length_scale=length_scale, time_scale=time_scale, rod_length=rod,
                      sample_interval=interval, ground=plane)


def check_file(path: str | os.PathLike[str], space: ParameterSpace | None = None) -> DataReport:
    """Load a trajectory file and check it. A file the loader refuses gives a ``format`` error with the
    loader's message, followed by the findings on the file as read, when it can be read."""
    from physics.trajectory import load_trajectory

    try:
        return check_trajectory(load_trajectory(path), space, source=str(path))
    except TrajectoryFormatError as exc:
        refused = Finding("format", "error", str(exc))
    try:
        with xr.open_dataset(path) as raw:
            report = check_trajectory(raw.load(), space, source=str(path))
    except Exception:  # netCDF4/xarray raise many types for unreadable files; the loader said why
        return DataReport((refused,), source=str(path))
    rest = tuple(f for f in report.findings if f.code != "format")
    return DataReport((refused, *rest), source=report.source, length_scale=report.length_scale,
                      time_scale=report.time_scale, rod_length=report.rod_length,
                      sample_interval=report.sample_interval, ground=report.ground)


def require_clean(datasets: Sequence[xr.Dataset], sources: Sequence[str], space: ParameterSpace | None = None,
                  ) -> list[DataReport]:
    """Check every trajectory; raise :class:`DataCheckError` with one line per error of any of them
    (and a last line on how to see everything or skip), else return the reports."""
    reports = [check_trajectory(ds, space, source=str(src)) for ds, src in zip(datasets, sources, strict=True)]
    errors = [line for report in reports for line in report.lines(severities=("error",))]
    if errors:
        raise DataCheckError("\n".join([*errors, "Run `tensegrid check FILE ...` for the whole report, or pass "
                                                  "--skip-checks to run anyway."]))
    return reports


def require_rods_in_box(reports: Sequence[DataReport], space: ParameterSpace) -> None:
    """Raise :class:`ParameterError` (one line: the file, the rods' measured length, the box and the
    options that fix it) when a report's median rod length [m] lies more than ROD_LENGTH_TOLERANCE
    outside the rod_length box of ``space``: no θ in that box can place the markers where they are."""
    _, lo, hi = _t6_box(space, "rod_length")
    for report in reports:
        rod = report.rod_length
        if not np.isfinite(rod) or lo - ROD_LENGTH_TOLERANCE <= rod <= hi + ROD_LENGTH_TOLERANCE:
            continue
        off = 1e3 * (lo - rod if rod < lo else rod - hi)
        raise ParameterError(f"{report.source or 'the data'}: the rods measure {rod:.4g} m (median distance of "
                             f"their end markers), {off:.0f} mm outside the rod_length box [{lo:.4g}, {hi:.4g}] m "
                             f"(tolerance {1e3 * ROD_LENGTH_TOLERANCE:g} mm); give --bounds rod_length="
                             f"{0.9 * rod:.3g}:{1.1 * rod:.3g} or --nominal rod_length={rod:.4g}.")
