"""How the end caps meet the floor, read from the nodes that touch it during the flops.

A node in contact with the floor sits, along the floor's normal n, at a height that depends on
the shape of its end cap and on the rod's tilt α (sin α = |n · d| / |d|, d the rod's axis):

    sphere cap (the T6's contact model):   h = b + r
    flat cylinder end (resting on its rim): h = b + r cos α

with r the cap radius and b a constant offset of the observations along n (a marker offset; the
floor passes through the origin of the data's frame). At rest the three contact rods share one
tilt by symmetry, so the rest pose cannot tell a flat cap from a sphere nor b from r. During a
flop the contact rods tilt through tens of degrees, and the samples (α_i, h_i) separate them:
both laws are fitted by linear least squares (sphere: one constant c = b + r; flat: b and r),
and the flat law wins when its RMS residual is DECISIVE_RATIO times smaller, the sphere law when
the tilt term lowers the RMS by less than the factor SPHERE_RATIO (otherwise, or when the tilts
hardly vary, the shape is "undecided"). Only the flat law gives b by itself; under the sphere law
b and r are one number.

Contact samples: nodes within ``band`` of the lowest node height of their trajectory along n,
moving along n slower than ``max_speed`` (a node lifting off or landing is not resting on its
cap); the fit is repeated once on the samples within max(``min_residual``, 4 · 1.4826 · MAD) of
the flat law, which holds the sphere law as its case r = 0 (a node hovering just above the floor
is not in contact).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr

from physics.effects.world import resting_normal

__all__ = ["ContactLaw", "contact_law", "contact_samples", "CONTACT_BAND", "CONTACT_SPEED", "DECISIVE_RATIO",
           "SPHERE_RATIO", "MIN_TILT_SPREAD", "MIN_SAMPLES"]

#: height band [m] above a trajectory's lowest node height in which a node may be in contact
#: (a rod of radius 0.06 m tilting from 20° to 60° moves its flat-cap node by 26 mm)
CONTACT_BAND = 0.03
#: largest speed [m/s] along the floor normal of a node counted as resting on its cap
CONTACT_SPEED = 0.05
#: RMS ratio by which one law must beat the other to be chosen
DECISIVE_RATIO = 2.0
#: largest RMS ratio (sphere / flat) at which the tilt term explains too little for a flat cap
SPHERE_RATIO = 1.2
#: least standard deviation of cos α over the contact samples for the two laws to differ
MIN_TILT_SPREAD = 0.02
#: fewest contact samples for a reading
MIN_SAMPLES = 30


@dataclass(frozen=True)
class ContactLaw:
    """The two contact laws fitted to the contact samples (module docstring).

    shape: "flat", "sphere" or "undecided"; offset [m]: b of the flat law (None unless flat);
    radius [m]: r of the flat law; sphere_height [m]: c = b + r of the sphere law; rms_flat,
    rms_sphere [m]: the RMS residuals; offset_se [m]: the standard error of b under the flat law;
    tilt_spread: the standard deviation of cos α; samples: how many contact samples were fitted."""

    shape: str
    offset: float | None
    radius: float
    sphere_height: float
    rms_flat: float
    rms_sphere: float
    offset_se: float
    tilt_spread: float
    samples: int

    def text(self) -> str:
        """One line: the chosen shape, the offset it gives and both residuals [mm]."""
        b = "offset not separable from the radius" if self.offset is None else \
            f"offset {1e3 * self.offset:+.1f} ± {1e3 * self.offset_se:.1f} mm"
        return (f"end caps {self.shape}: {b}; flat r = {1e3 * self.radius:.1f} mm (RMS {1e3 * self.rms_flat:.2f} mm), "
                f"sphere b + r = {1e3 * self.sphere_height:.1f} mm (RMS {1e3 * self.rms_sphere:.2f} mm); "
                f"{self.samples} samples, spread of cos α {self.tilt_spread:.3f}")


def _floor_normal(trajectories: Sequence[xr.Dataset]) -> np.ndarray:
    """The floor's unit normal: the resting robot's (physics.effects.world.resting_normal), z without one."""
    n = resting_normal(trajectories)
    return np.array([0.0, 0.0, 1.0]) if n is None else n / np.linalg.norm(n)


def contact_samples(ds: xr.Dataset, normal: np.ndarray, *, band: float = CONTACT_BAND,
                    max_speed: float = CONTACT_SPEED) -> tuple[np.ndarray, np.ndarray]:
    """(cos α, h) of the contact samples of one trajectory (module docstring), each (N,).

    normal (3,): the floor's unit normal; h = n · x [m] of the node, α its rod's tilt to the floor."""
    nodes = np.asarray(ds["nodes"].transpose("time", "node", "axis").values, float)      # T x 12 x 3
    t = np.asarray(ds["time"].values, float)
    height = nodes @ normal                                                                # T x 12
    if not np.isfinite(height).any():
        return np.empty(0), np.empty(0)
    axis = nodes[:, 1::2] - nodes[:, 0::2]                                                 # T x 6 x 3
    with np.errstate(invalid="ignore"):
        sin_tilt = np.abs(axis @ normal) / np.linalg.norm(axis, axis=2)
    cos_tilt = np.repeat(np.sqrt(np.clip(1.0 - sin_tilt ** 2, 0.0, 1.0)), 2, axis=1)      # T x 12
    speed = np.abs(np.gradient(height, t, axis=0)) if len(t) > 1 else np.full_like(height, np.inf)
    with np.errstate(invalid="ignore"):
        keep = (height <= np.nanmin(height) + band) & (speed <= max_speed) & np.isfinite(cos_tilt)
    return cos_tilt[keep], height[keep]


def _fits(cos_tilt: np.ndarray, height: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Least squares of both laws: (b, r) of the flat law, its residuals, the sphere's constant, and
    the standard error of b."""
    design = np.c_[np.ones_like(cos_tilt), cos_tilt]
    coef = np.linalg.lstsq(design, height, rcond=None)[0]
    resid = height - design @ coef
    dof = max(len(height) - 2, 1)
    cov = np.linalg.pinv(design.T @ design) * float(resid @ resid) / dof
    return coef, resid, float(np.mean(height)), float(np.sqrt(max(cov[0, 0], 0.0)))


def _between_se(cos_tilt: np.ndarray, height: np.ndarray, which: np.ndarray) -> float:
    """Standard error of b from its spread over trajectories, std(b_k) / sqrt(K), over the K
    trajectories with at least MIN_SAMPLES contact samples each; 0 with fewer than two."""
    offsets = [_fits(cos_tilt[which == k], height[which == k])[0][0] for k in np.unique(which)
               if (which == k).sum() >= MIN_SAMPLES]
    return float(np.std(offsets, ddof=1) / np.sqrt(len(offsets))) if len(offsets) >= 2 else 0.0


def contact_law(trajectories: Sequence[xr.Dataset], *, band: float = CONTACT_BAND, max_speed: float = CONTACT_SPEED,
                min_residual: float = 0.002) -> ContactLaw | None:
    """Both contact laws fitted to the contact samples of ``trajectories`` (module docstring);
    None with fewer than MIN_SAMPLES contact samples. The offset's standard error is the larger
    of the least-squares one and the spread of b over the trajectories (samples of one flop are
    not independent)."""
    normal = _floor_normal(trajectories)
    parts = [contact_samples(ds, normal, band=band, max_speed=max_speed) for ds in trajectories]
    cos_tilt = np.concatenate([p[0] for p in parts])
    height = np.concatenate([p[1] for p in parts])
    which = np.concatenate([np.full(len(p[1]), k) for k, p in enumerate(parts)])
    if len(height) < MIN_SAMPLES:
        return None
    coef, resid, sphere, se = _fits(cos_tilt, height)
    spread = 1.4826 * np.median(np.abs(resid - np.median(resid)))
    inliers = np.abs(resid - np.median(resid)) <= max(min_residual, 4.0 * spread)
    if inliers.sum() >= MIN_SAMPLES:
        cos_tilt, height, which = cos_tilt[inliers], height[inliers], which[inliers]
        coef, resid, sphere, se = _fits(cos_tilt, height)
    rms_flat, rms_sphere = float(np.sqrt(np.mean(resid ** 2))), float(np.std(height))
    tilt_spread = float(np.std(cos_tilt))
    if tilt_spread < MIN_TILT_SPREAD:
        shape = "undecided"
    elif rms_sphere >= DECISIVE_RATIO * rms_flat:
        shape = "flat"
    elif rms_sphere <= SPHERE_RATIO * rms_flat:
        shape = "sphere"
    else:
        shape = "undecided"
    se = max(se, _between_se(cos_tilt, height, which))
    return ContactLaw(shape, float(coef[0]) if shape == "flat" else None, float(coef[1]), sphere, rms_flat,
                      rms_sphere, se, tilt_spread, int(len(height)))
