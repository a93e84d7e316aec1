"""Data checks against the robot: node labels, up axis and floor, and the controls (physics.checks runs them).

Every function takes arrays already in SI units (nodes T x 12 x 3 [m], time T [s], controls
T x 24 [m as the file gives them]) and returns a list of :class:`~physics.findings.Finding`.
"""
from __future__ import annotations

import warnings

import numpy as np

from physics.findings import Finding, Severity
from physics.geometry import CABLE_NODES
from physics.ground import GroundPlane, plane_below, rest_window
from physics.labels import find_rod_pairs, flip_rod_ends, pair_distances, relabel_order, rod_lengths

__all__ = ["check_rod_labels", "check_ground", "check_controls", "ROD_TOLERANCE", "RIGID_SPREAD", "LEVEL_DEG",
           "TILT_DEG", "REST_MOTION", "LENGTH_UNITS"]

#: A rod whose median length differs from the others' by more than this is mislabelled [m].
ROD_TOLERANCE = 0.1
#: A rod whose length varies (5-95 % over time) by more than this is not one rigid body [m].
RIGID_SPREAD = 0.03
#: A plane through the lowest nodes within this angle of an axis makes that axis "level" [deg].
LEVEL_DEG = 10.0
#: A floor tilted by more than this from z is reported as sloped [deg].
TILT_DEG = 1.0
#: A node that moves more than this over the rest window means the robot is not at rest [m].
REST_MOTION = 0.01
#: Offset of the floor from z = 0 that is reported as a warning and as an error [m].
HEIGHT_WARN, HEIGHT_ERROR = 0.03, 0.1
#: Unit factors tried for lengths: (metres per unit, name).
LENGTH_UNITS = ((1.0, "metres"), (1e-2, "centimetres"), (1e-3, "millimetres"))
_AXIS_NAMES = ("x", "y", "z")
#: A proper rotation that takes each signed up axis to +z, as xarray code.
_TO_Z_UP = {
    "+y": "ds['nodes'] = ds['nodes'].roll(axis=1, roll_coords=False) maps (x, y, z) to (z, x, y).",
    "+x": "ds['nodes'] = ds['nodes'].roll(axis=2, roll_coords=False) maps (x, y, z) to (y, z, x).",
    "-z": "ds['nodes'] = ds['nodes'] * xr.DataArray([1, -1, -1], dims='axis') maps (x, y, z) to (x, -y, -z).",
    "-y": "roll(axis=1) as for y up, then multiply by [1, -1, -1]: (x, y, z) to (z, -x, -y).",
    "-x": "roll(axis=2) as for x up, then multiply by [1, -1, -1]: (x, y, z) to (y, -z, -x).",
}


def check_rod_labels(nodes: np.ndarray, rod_length: float) -> list[Finding]:
    """Rods whose median length is off the common one by > ROD_TOLERANCE (with the pairing of their
    ends that looks most like rods, physics.labels.find_rod_pairs), rods whose length spreads by
    > RIGID_SPREAD over time, and, when the rods are fine, cables longer than a rod (a rod's two
    end labels swapped). nodes (T x 12 x 3) [m]; rod_length the median rod length [m]."""
    distance, spread = pair_distances(nodes)
    rods = rod_lengths(distance)
    off = [i for i in range(6) if not abs(rods[i] - rod_length) <= ROD_TOLERANCE]
    if off:
        pairs, cost = find_rod_pairs(distance, spread, off, rod_length)
        listed = ", ".join(f"rod {i} (nodes {2 * i}-{2 * i + 1}) {rods[i]:.3f} m" for i in off)
        fix = ("no pairing of their ends makes rods of that length: check which marker is which end "
               "(rod i joins nodes 2i and 2i+1, docs/data-format.md)." if not pairs or cost > ROD_TOLERANCE else
               f"the ends pair up as {', '.join(f'{a}-{b}' for a, b in pairs)}; relabel the nodes, e.g. "
               f"ds = ds.isel(node={relabel_order(off, pairs)}).assign_coords(node=range(12)).")
        return [Finding("rod-ends-swapped", "error", f"{listed}, while the other rods measure {rod_length:.3f} m: "
                        "node labels are swapped between rods.", fix)]
    out: list[Finding] = []
    rod_spread = spread[np.arange(0, 12, 2), np.arange(1, 12, 2)]
    loose = [i for i in range(6) if rod_spread[i] > RIGID_SPREAD]
    if loose:
        listed = ", ".join(f"rod {i} by {rod_spread[i] * 100:.1f} cm" for i in loose)
        out.append(Finding("rod-not-rigid", "error", f"rod lengths vary over time (5-95 %): {listed}; a rigid rod "
                           "cannot.", "a marker is swapped or on the wrong body for part of the recording: fix the "
                           "labels from the time it starts, or set those samples to NaN."))
    long, flipped = flip_rod_ends(distance, rod_length)
    if long:
        swaps = ", ".join(f"{2 * i}<->{2 * i + 1}" for i in flipped)
        fix = (f"swap the two end labels of rod(s) {flipped} (nodes {swaps})." if flipped else
               "put the nodes in the T6 order of docs/data-format.md (cable ends end_a/end_b).")
        listed = "; ".join(long[:4]) + ("; ..." if len(long) > 4 else "")
        out.append(Finding("cable-ends", "error", f"{len(long)} cables are nearly as long as a rod ({listed}): node "
                           "labels do not match the cable layout.", fix))
    return out


def _signed_axes() -> list[tuple[str, np.ndarray]]:
    return [(f"{sign}{name}", np.eye(3)[k] * (1.0 if sign == "+" else -1.0))
            for k, name in enumerate(_AXIS_NAMES) for sign in ("+", "-")]


def check_ground(nodes: np.ndarray, time: np.ndarray, controls: np.ndarray | None, radius: float
                 ) -> tuple[list[Finding], GroundPlane | None]:
    """The up axis and the floor from the rest window (physics.ground): of the six signed axes, those
    whose lowest-nodes plane lies within LEVEL_DEG are level; up is +z if it is level and its contact
    nodes sit nearer one end-cap ``radius`` [m] above z = 0 than those of -z, else the level axis
    nearest that. Then the floor's tilt from z (> TILT_DEG warns) and its height (contact height -
    radius, > HEIGHT_WARN warns, > HEIGHT_ERROR fails). Returns (findings, the +z plane)."""
    window = rest_window(time, controls)
    planes = {name: plane_below(nodes[window], axis) for name, axis in _signed_axes()}
    up = planes["+z"]
    if up is None:
        return [Finding("ground", "warning", "fewer than three nodes are seen at rest; no ground plane.",
                        "start the recording with the robot at rest and all markers visible.")], None
    moved = rest_motion(nodes[window])
    if moved > REST_MOTION:
        seconds = time[window[-1]] - time[0]
        return [Finding("not-at-rest", "warning", f"a node moves {1e3 * moved:.0f} mm in the first {seconds:.2f} s, "
                        "before any command: the robot is not at rest, so no floor can be read from it.",
                        "start the recording with the robot resting on a face for 0.2 s.")], up
    level = {k: p for k, p in planes.items() if p is not None and p.tilt_deg <= LEVEL_DEG}
    best = min(level, key=lambda k: abs(level[k].contact_height - radius)) if level else None
    if best is not None and best != "+z" and ("+z" not in level or best == "-z"):
        what = "z points down" if best == "-z" else f"the up axis is {best[1]} ({best}), gravity along {best[1]}"
        return [Finding("up-axis", "error", f"the resting robot's lowest nodes lie level along {best} "
                        f"(tilt {level[best].tilt_deg:.1f} deg) but {up.tilt_deg:.0f} deg off along +z: {what}.",
                        "rotate the nodes (and velocities) to z up, gravity -z (docs/data-format.md): "
                        + _TO_Z_UP[best])], up
    normal = ", ".join(f"{v:+.3f}" for v in up.normal)
    out = [Finding("ground", "info", f"ground plane of the resting robot: normal ({normal}), height "
                   f"{up.height:.3f} m (contact nodes {list(up.nodes)}), tilt {up.tilt_deg:.2f} deg, residual "
                   f"{up.residual * 1e3:.2g} mm.")]
    if best is None:
        seconds = time[window[-1]] - time[0]
        out.append(Finding("not-at-rest", "warning", f"the lowest nodes in the first {seconds:.2f} s lie "
                           f"{up.tilt_deg:.0f} deg off level along every axis: the robot is not at rest on a "
                           "floor.", "start the recording with the robot resting on a face."))
        return out, up
    if up.tilt_deg > TILT_DEG:
        slope_x, slope_y = np.arcsin(up.normal[:2])
        out.append(Finding("ground-tilt", "warning", f"the floor is tilted {up.tilt_deg:.1f} deg from level (normal "
                           f"({normal}) in the world frame): a sloped floor, or a frame not aligned with gravity; the "
                           "bare model's ground is the plane z = 0.", "if the frame is tilted, rotate z onto gravity; "
                           "if the floor slopes, keep the world frame and add the ground_slope effect, a floor "
                           f"tilted under vertical gravity (slope_x ~ {slope_x:+.3f}, slope_y ~ {slope_y:+.3f} rad; "
                           "tensegrid diagnose starts its search there)."))
    offset = up.contact_height - radius
    if abs(offset) > HEIGHT_WARN:
        severity: Severity = "error" if abs(offset) > HEIGHT_ERROR else "warning"
        out.append(Finding("ground-height", severity, f"the floor lies at z = {offset:+.3f} m (contact nodes at "
                           f"{up.contact_height:.3f} m minus the end-cap radius {radius:.3f} m), not at 0.",
                           f"shift the frame: ds['nodes'].loc[dict(axis='z')] -= {offset:.3f}."))
    return out, up


def rest_motion(window: np.ndarray) -> float:
    """Largest node displacement [m] over a rest window (K x 12 x 3): the mean of its last quarter
    minus that of its first (averaging keeps marker noise out); 0 for fewer than two samples."""
    if len(window) < 2:
        return 0.0
    q = max(1, len(window) // 4)
    with warnings.catch_warnings():             # a node never seen in a quarter: NaN, left out below
        warnings.simplefilter("ignore", RuntimeWarning)
        shift = np.nanmean(window[-q:], axis=0) - np.nanmean(window[:q], axis=0)
    return float(np.nan_to_num(np.linalg.norm(shift, axis=-1), nan=0.0).max())


def _cable_lengths_at_rest(nodes: np.ndarray, time: np.ndarray, controls: np.ndarray) -> np.ndarray:
    window = nodes[rest_window(time, controls)]
    lengths = np.linalg.norm(window[:, CABLE_NODES[:, 0]] - window[:, CABLE_NODES[:, 1]], axis=-1)
    return np.asarray(np.nanmedian(lengths, axis=0)) if np.isfinite(lengths).any() else np.full(24, np.nan)


def check_controls(controls: np.ndarray | None, reference: str | None, rest_range: tuple[float, float],
                   nodes: np.ndarray, time: np.ndarray, slack: float) -> list[Finding]:
    """The controls' presence, units (the unit of LENGTH_UNITS that brings their median into the
    plausible range [0.5 lo, 1.5 hi] of build rest lengths ``rest_range`` [m], a controller changing
    them by less than half), range, and meaning: commands equal to the measured cable lengths at rest
    (within 2 cm, while rest lengths are shorter by pretension / k = ``slack`` [m]) are cable lengths,
    not rest lengths. controls (T x 24) as the file gives them; reference its length_reference."""
    if controls is None or not np.isfinite(controls).any():
        return [Finding("controls-missing", "error", "no finite 'controls' (commanded rest lengths).",
                        "add the motor commands as 'controls' (time, cable) [m] (docs/data-format.md).")]
    lo, hi = 0.5 * rest_range[0], 1.5 * rest_range[1]
    median = float(np.nanmedian(controls))
    scale = next((f for f, _ in LENGTH_UNITS if lo <= median * f <= hi), None)
    said = f"length_reference={reference!r}" if reference else "no length_reference (encoder readings assumed)"
    if scale is None:
        return [Finding("controls-range", "error", f"controls have median {median:.4g} ({said}), far from rest "
                        f"lengths [{lo:.2f}, {hi:.2f}] m in any length unit.", "controls must be commanded "
                        "target rest lengths [m] per cable, not motor angles, tensions or positions.")]
    out: list[Finding] = []
    if scale != 1.0:
        out.append(Finding("controls-units", "error", f"controls have median {median:.4g}: "
                           f"{median * scale:.3f} m in {dict(LENGTH_UNITS)[scale]}.",
                           f"convert to metres: ds['controls'] = ds['controls'] * {scale:g}."))
    c = controls * scale
    c_lo, c_hi = float(np.nanmin(c)), float(np.nanmax(c))
    moving = int(np.sum(np.nanmax(c, axis=0) - np.nanmin(c, axis=0) > 1e-6))
    out.append(Finding("controls", "info", f"controls from {c_lo:.3f} to {c_hi:.3f} m, {moving} of 24 cables "
                       f"commanded to change; {said}."))
    if c_lo < lo or c_hi > hi:
        out.append(Finding("controls-range", "warning", f"controls reach [{c_lo:.3f}, {c_hi:.3f}] m, outside "
                           f"[{lo:.2f}, {hi:.2f}] m (build rest lengths of the box, changed by at most half).",
                           "check the controls' units and offset, or widen the box."))
    cables = _cable_lengths_at_rest(nodes, time, c)
    first = c[np.argmax(np.isfinite(c).all(axis=1))]
    if np.isfinite(cables).all() and np.nanmedian(np.abs(first - cables)) < min(0.02, 0.5 * slack):
        out.append(Finding("controls-semantics", "warning", "the first controls equal the measured cable lengths "
                           f"(median difference {np.nanmedian(np.abs(first - cables)) * 1e3:.1f} mm): they look like "
                           f"cable lengths, not rest lengths (shorter by pretension / k = {slack:.3f} m).",
                           "give the commanded target rest lengths (the motors' encoder readings)."))
    if reference not in (None, "encoder", "true"):
        out.append(Finding("controls-reference", "warning", f"length_reference={reference!r} is neither "
                           "'encoder' nor 'true'; it is read as 'encoder'.", "set it to 'encoder' or 'true'."))
    return out
