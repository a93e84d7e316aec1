"""The ground plane under a trajectory's resting robot, estimated from its lowest nodes.

A T6 at rest stands on three end caps, so the three lowest node centres (along the up axis u) lie
on a plane parallel to the floor, one end-cap radius above it. Over the rest window (the samples
of the first ``seconds`` before the controls first change) the positions of those three nodes
(K x 3 x 3 [m]) are fitted by least squares::

    c = mean of the points,   n = right singular vector of (points - c) with the smallest value,
    n oriented so that n . u > 0,   plane: n . x = h with h = n . c,
    tilt = arccos(n . u),   residual = RMS of (points - c) . n.

The same estimate tells the data checks (physics.checks) which axis is up and whether the floor
is sloped, and gives an effect search the floor's normal in the world frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

__all__ = ["GroundPlane", "rest_window", "plane_below", "ground_plane", "REST_SECONDS", "CONTACT_NODES"]

#: Length of the rest window at the start of a trajectory [s].
REST_SECONDS = 0.2
#: Number of lowest nodes that carry a resting T6 (one closed or open face).
CONTACT_NODES = 3


@dataclass(frozen=True, eq=False)
class GroundPlane:
    """A plane n . x = height under the resting robot.

    normal (3,) unit vector pointing up (away from the floor); height [m] the plane's offset along
    it (the plane of the contact nodes' centres, one end-cap radius above the floor); tilt_deg the
    angle between the normal and the up axis it was searched along [deg]; residual the RMS distance
    of the contact nodes from the plane over the rest window [m]; nodes the contact nodes' indices;
    contact_height the mean coordinate of the contact nodes along the up axis [m].
    """

    normal: np.ndarray
    height: float
    tilt_deg: float
    residual: float
    nodes: tuple[int, ...]
    contact_height: float


def rest_window(time: np.ndarray, controls: np.ndarray | None, seconds: float = REST_SECONDS) -> np.ndarray:
    """Indices of the samples at rest: within ``seconds`` of the first sample and not after the first
    change of any control by more than 1e-6 (the sample where it changes still shows the pose
    before the new command acts). time (T,) [s]; controls (T x 24) or None; returns (K,) with K >= 1."""
    t = np.asarray(time, dtype=float)
    keep = t - t[0] <= seconds
    if controls is not None and len(controls) == len(t):
        c = np.asarray(controls, dtype=float)
        changed = np.nan_to_num(np.abs(c - c[0]), nan=0.0).max(axis=1) > 1e-6
        if changed.any():
            keep[int(np.argmax(changed)) + 1:] = False
    keep[0] = True
    return np.flatnonzero(keep)


def plane_below(nodes: np.ndarray, up: np.ndarray) -> GroundPlane | None:
    """The plane through the ``CONTACT_NODES`` lowest nodes along ``up`` (see the module docstring).

    nodes (K x 12 x 3) [m], NaN for missing markers; up (3,) the candidate up axis. Returns None
    when fewer than three nodes have a finite position in the window."""
    u = np.asarray(up, dtype=float) / np.linalg.norm(up)
    with np.errstate(invalid="ignore"):
        pose = _nanmean(nodes)
    finite = np.flatnonzero(np.isfinite(pose).all(axis=1))
    if finite.size < CONTACT_NODES:
        return None
    lowest = finite[np.argsort(pose[finite] @ u)[:CONTACT_NODES]]
    points = nodes[:, lowest].reshape(-1, 3)
    points = points[np.isfinite(points).all(axis=1)]
    if len(points) < CONTACT_NODES:
        return None
    centre = points.mean(axis=0)
    normal = np.linalg.svd(points - centre)[2][-1]
    normal = normal if normal @ u >= 0 else -normal
    tilt = float(np.degrees(np.arccos(np.clip(normal @ u, -1.0, 1.0))))
    residual = float(np.sqrt(np.mean(((points - centre) @ normal) ** 2)))
    return GroundPlane(normal=normal, height=float(normal @ centre), tilt_deg=tilt, residual=residual,
                       nodes=tuple(int(i) for i in sorted(lowest)), contact_height=float(centre @ u))


def _nanmean(nodes: np.ndarray) -> np.ndarray:
    """Mean over the first axis ignoring NaN, NaN where a node is never seen: (K x 12 x 3) -> (12 x 3)."""
    count = np.isfinite(nodes).sum(axis=0)
    total = np.nansum(nodes, axis=0)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def ground_plane(ds: xr.Dataset, *, up: tuple[float, float, float] = (0.0, 0.0, 1.0),
                 seconds: float = REST_SECONDS, length_scale: float = 1.0) -> GroundPlane | None:
    """The ground plane of a trajectory Dataset (docs/data-format.md) from its rest window.

    up: the axis taken as up (z by the data format); length_scale: metres per unit of ``nodes``
    (1e-3 for a file in millimetres). Returns None when the rest window has fewer than three
    finite nodes."""
    nodes = np.asarray(ds["nodes"].transpose("time", "node", "axis").values, dtype=float) * length_scale
    controls = np.asarray(ds["controls"].transpose("time", "cable").values, float) if "controls" in ds else None
    window = rest_window(np.asarray(ds["time"].values, dtype=float), controls, seconds)
    return plane_below(nodes[window], np.asarray(up, dtype=float))
