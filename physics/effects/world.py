"""Effects on the world's setup: a sloped floor, the end caps' contact radius, a point mass on a rod."""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr

from physics.checks_robot import LEVEL_DEG, REST_MOTION, rest_motion
from physics.effects.base import Effect, ModelSetup
from physics.errors import ParameterError
from physics.ground import GroundPlane, plane_below, rest_window
from physics.parameters import T6_NOMINAL, Parameter

__all__ = ["GroundSlope", "MEASURED_SLOPE_WIDTH", "EVIDENT_TILT", "MEASURED_CONTACT_WIDTH", "resting_planes",
           "resting_normal", "resting_tilt", "resting_height", "contact_excess", "slope_normal", "EndCapRadius",
           "PointMass"]

#: ± half-width [rad] of a measured slope's box (0.5°): physics.ground's plane at rest is within
#: 0.3° of the floor on the foreign testbed's 3° slope and level ground (tests/testbed)
MEASURED_SLOPE_WIDTH = float(np.radians(0.5))
#: tilt [rad] of a measured floor beyond which the slope is evident at rest (GroundSlope.evident,
#: 1°): twice the box's half-width, over three times physics.ground's error on the testbed (0.3°)
EVIDENT_TILT = float(np.radians(1.0))
#: ± half-width [m] of a box around a contact height measured at rest (a sensor bias, a cap radius):
#: the model's caps rest their nodes at the rod radius, within ±6 mm of nominal over its box, and
#: another engine's caps rest at other heights than DART's spheres (the foreign testbed's flat
#: cylinder ends: 10 mm lower at the same radius)
MEASURED_CONTACT_WIDTH = 0.02


class GroundSlope(Effect):
    """The floor descends by ``slope_x`` along +x and ``slope_y`` along +y [rad], in the world frame.

    The data contract's frame is the world's (z up, gravity along −z), so a sloped floor is a
    tilted ground plane through the origin, not a tilted gravity: its unit normal is
    n = (sin slope_x, sin slope_y, sqrt(1 − sin² slope_x − sin² slope_y)) and gravity stays −g ẑ.
    The resting robot's contact nodes then lie on a plane with that normal, which the data show
    at rest (physics.ground.ground_plane: slope_x = arcsin n_x, slope_y = arcsin n_y).

    ``measured``: (slope_x, slope_y) read from the data at rest (:meth:`bind`); the parameters
    then keep a box of ± ``width`` [rad] around it, so that a fit of the dynamics cannot move the
    floor where the resting robot shows it is not (on another engine's data the dynamics alone
    prefer tilts of several degrees on flat ground, to absorb what the model lacks)."""

    name = "ground_slope"
    description = "floor tilted about the x and y axes (world frame, gravity -z)"

    def __init__(self, measured: Sequence[float] | None = None, width: float = MEASURED_SLOPE_WIDTH) -> None:
        self.measured = None if measured is None else (float(measured[0]), float(measured[1]))
        if not (np.isfinite(width) and width > 0):
            raise ParameterError(f"GroundSlope width must be a positive angle [rad], got {width!r}.")
        self.width = float(width)

    def parameters(self) -> tuple[Parameter, ...]:
        if self.measured is None:
            return (Parameter("slope_x", "rad", 0.0, -0.15, 0.15, "floor descends along +x", minimum=-np.inf),
                    Parameter("slope_y", "rad", 0.0, -0.15, 0.15, "floor descends along +y", minimum=-np.inf))
        return tuple(Parameter(n, "rad", v, v - self.width, v + self.width, f"floor descends along +{axis} "
                               "(measured at rest)", minimum=-np.inf)
                     for n, axis, v in zip(("slope_x", "slope_y"), "xy", self.measured, strict=True))

    @property
    def off(self) -> dict[str, float] | None:
        """Level ground for the free slope; None once measured (its box need not hold a level floor)."""
        return None if self.measured is not None else super().off

    @property
    def evident(self) -> bool:
        """A measured floor tilted by more than EVIDENT_TILT: the resting robot shows it, and nothing
        else in the model tilts the plane its contact nodes lie on."""
        if self.measured is None:
            return False
        return bool(np.arccos(np.clip(slope_normal(*self.measured)[2], -1.0, 1.0)) > EVIDENT_TILT)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.ground_normal = slope_normal(float(values["slope_x"]), float(values["slope_y"]))

    def start(self, trajectories: Sequence[xr.Dataset]) -> dict[str, float]:
        """The slope of the plane the resting robot's contact nodes lie on (physics.ground), median
        over the trajectories that start at rest, clipped to the box; nominal (level) without one."""
        tilt = resting_tilt(trajectories)
        if tilt is None:
            return super().start(trajectories)
        return {q.name: float(np.clip(v, q.lower, q.upper)) for q, v in zip(self.parameters(), tilt, strict=True)}

    def bind(self, trajectories: Sequence[xr.Dataset]) -> Effect:
        """The slope measured at rest (:func:`resting_tilt`, ± ``width``); itself when no trajectory
        starts at rest or the slope is measured already."""
        tilt = resting_tilt(trajectories) if self.measured is None else None
        return self if tilt is None else GroundSlope(measured=tilt, width=self.width)

    def config(self) -> dict:
        if self.measured is None:
            return {"effect": self.name}
        return {"effect": self.name, "measured": list(self.measured), "width": self.width}


def resting_planes(trajectories: Sequence[xr.Dataset]) -> list[GroundPlane]:
    """The planes under the resting robot (physics.ground.plane_below of each trajectory's rest
    window), of the trajectories that start at rest: no node moves more than
    physics.checks_robot.REST_MOTION over the window, and the plane lies within LEVEL_DEG of level."""
    planes = []
    for ds in trajectories:
        nodes = np.asarray(ds["nodes"].transpose("time", "node", "axis").values, float)
        controls = np.asarray(ds["controls"].transpose("time", "cable").values, float) if "controls" in ds else None
        window = nodes[rest_window(np.asarray(ds["time"].values, float), controls)]
        plane = plane_below(window, np.array([0.0, 0.0, 1.0]))
        if plane is not None and plane.tilt_deg <= LEVEL_DEG and rest_motion(window) <= REST_MOTION:
            planes.append(plane)
    return planes


def resting_normal(trajectories: Sequence[xr.Dataset]) -> np.ndarray | None:
    """The median (3,) of the normals of :func:`resting_planes` (componentwise, not renormalised);
    None when no trajectory starts at rest."""
    planes = resting_planes(trajectories)
    return np.median([p.normal for p in planes], axis=0) if planes else None


def resting_tilt(trajectories: Sequence[xr.Dataset]) -> tuple[float, float] | None:
    """(slope_x, slope_y) [rad] of the floor the resting robot shows: arcsin of the x and y
    components of :func:`resting_normal`, clipped to ±0.15 rad; None when no trajectory starts at
    rest."""
    normal = resting_normal(trajectories)
    if normal is None:
        return None
    return (float(np.clip(np.arcsin(normal[0]), -0.15, 0.15)), float(np.clip(np.arcsin(normal[1]), -0.15, 0.15)))


def resting_height(trajectories: Sequence[xr.Dataset]) -> float | None:
    """Height [m] of the resting robot's contact nodes above the floor they lie on: the median
    offset n·x of :func:`resting_planes` (a node on a sphere cap of radius r touching a floor
    through the origin sits at r); None when no trajectory starts at rest."""
    planes = resting_planes(trajectories)
    return float(np.median([p.height for p in planes])) if planes else None


def contact_excess(trajectories: Sequence[xr.Dataset]) -> float | None:
    """How much higher [m] the resting robot's contact nodes are seen than the nominal T6 rests
    them: :func:`resting_height` minus the nominal rod radius. A sensor bias b and a cap radius
    change Δr both add to it (h = r + Δr + b); None when no trajectory starts at rest."""
    height = resting_height(trajectories)
    return None if height is None else height - T6_NOMINAL["radius"]


def slope_normal(slope_x: float, slope_y: float) -> np.ndarray:
    """Unit normal (3,) of a floor descending by ``slope_x`` along +x and ``slope_y`` along +y [rad]."""
    sx, sy = np.sin(slope_x), np.sin(slope_y)
    return np.array([sx, sy, np.sqrt(max(0.0, 1.0 - sx * sx - sy * sy))])


class EndCapRadius(Effect):
    """The end caps touch the ground with a sphere of radius ``radius + cap_radius_change`` [m]
    instead of ``radius`` (a flatter or smaller cap than the rod's end segment).

    ``measured``: the change the resting robot shows (:meth:`bind`): its contact nodes are seen at
    h = r + Δr, so Δr = h − r (:func:`contact_excess`); the parameter then keeps ± ``width`` around
    it, within the free box: a fit of the dynamics cannot sink the model's robot into the floor
    (or lift it off) where the resting robot shows it is not."""

    name = "end_cap_radius"
    description = "contact radius of the end caps differs from the rod radius"
    FREE = (-0.04, 0.03)

    def __init__(self, measured: float | None = None, width: float = MEASURED_CONTACT_WIDTH) -> None:
        if not (np.isfinite(width) and width > 0):
            raise ParameterError(f"EndCapRadius width must be a positive length [m], got {width!r}.")
        box = None if measured is None or not np.isfinite(measured) else self._box(float(measured), width)
        if measured is not None and box is None:
            raise ParameterError(f"EndCapRadius measured = {measured!r} m leaves no change within ±{width} m inside "
                                 f"{self.FREE} m.")
        self.measured = None if measured is None else float(measured)
        self.width = float(width)
        self._measured_box = box

    @classmethod
    def _box(cls, measured: float, width: float) -> tuple[float, float] | None:
        """[measured − width, measured + width] within the free box; None when they do not overlap."""
        lower, upper = max(measured - width, cls.FREE[0]), min(measured + width, cls.FREE[1])
        return (lower, upper) if lower < upper else None

    def parameters(self) -> tuple[Parameter, ...]:
        if self.measured is None or self._measured_box is None:
            return (Parameter("cap_radius_change", "m", 0.0, *self.FREE, "contact radius minus rod radius",
                              minimum=-np.inf),)
        lower, upper = self._measured_box
        return (Parameter("cap_radius_change", "m", float(np.clip(self.measured, lower, upper)), lower, upper,
                          "contact radius minus rod radius (measured at rest)", minimum=-np.inf),)

    @property
    def off(self) -> dict[str, float] | None:
        """The rod's own radius for the free effect; None once measured (its box need not hold it)."""
        return None if self.measured is not None else super().off

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        radius = setup.cap_radius + values["cap_radius_change"]
        if radius < 0.005:
            raise ParameterError(f"cap_radius_change = {values['cap_radius_change']} m leaves a contact radius of "
                                 f"{radius:.4f} m; it must stay >= 0.005 m.")
        setup.cap_radius = radius

    def bind(self, trajectories: Sequence[xr.Dataset]) -> Effect:
        """The change measured at rest (:func:`contact_excess`, ± ``width``); itself when no trajectory
        starts at rest, the measurement leaves no change inside the free box, or it is measured already."""
        excess = contact_excess(trajectories) if self.measured is None else None
        if excess is None or self._box(excess, self.width) is None:
            return self
        return EndCapRadius(measured=excess, width=self.width)

    def config(self) -> dict:
        if self.measured is None:
            return {"effect": self.name}
        return {"effect": self.name, "measured": self.measured, "width": self.width}


class CylinderCaps(Effect):
    """The rods touch the ground with their end cylinders instead of spheres at the nodes: a cylinder
    of radius ``radius`` (the contact radius, :class:`EndCapRadius` included) and length
    l_e = (rod_length − rod_length_mp) / 2 whose outer face is centred on the node, as the rod's
    mass model already has it (physics.geometry.rod_mass_properties). A tilted rod then rests on
    the rim of its end face, its node r cos α above the floor (α: the rod's tilt), not r. A
    replacement without parameters of its own."""

    name = "cylinder_caps"
    description = "the rods touch the ground with their end cylinders, not with spheres at the nodes"
    switchable = False

    def parameters(self) -> tuple[Parameter, ...]:
        return ()

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        length = 0.5 * (params["rod_length"] - params["rod_length_mp"])
        if length <= 0.005:
            raise ParameterError(f"cylinder_caps needs end segments longer than 5 mm: rod_length − rod_length_mp = "
                                 f"{2 * length:.4f} m.")
        setup.cap_length = float(length)


class PointMass(Effect):
    """A point mass ``point_mass`` [kg] on the axis of rod ``rod`` at ``position`` × half the rod
    length from its centre (toward node 2·rod + 1): a sensor box or battery nobody modelled.

    ``rod=None`` is the mass whose place is unknown, as criticism's catalog holds it: its
    :meth:`placements` are the 12 masses at ± ``position`` on each rod (6 at the centre, ``position`` 0),
    and it builds no model itself."""

    name = "point_mass"
    description = "an extra point mass on one rod"

    def __init__(self, rod: int | None = 0, position: float = 0.6) -> None:
        if rod is not None and rod not in range(6):
            raise ParameterError(f"PointMass.rod must be a rod index in 0..5 (or None: unplaced), got {rod!r}.")
        if not (-1.0 <= position <= 1.0):
            raise ParameterError("PointMass.position must be in [-1, 1] (fraction of the half length), got "
                                 f"{position!r}.")
        self.rod, self.position = (None if rod is None else int(rod)), float(position)

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("point_mass", "kg", 0.0, 0.0, 3.0, "extra mass on one rod", strict=False),)

    def placements(self) -> tuple[Effect, ...]:
        if self.rod is not None:
            return (self,)
        sides = (1.0, -1.0) if self.position else (1.0,)          # at the centre both ends are one place
        return tuple(PointMass(rod, side * self.position) for rod in range(6) for side in sides)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        if self.rod is None:
            raise ParameterError("PointMass(rod=None) has no place to build a model with: give its rod, or let "
                                 "criticism choose one of its placements().")
        if values["point_mass"] > 0:
            setup.point_masses.append((self.rod, float(values["point_mass"]),
                                       self.position * 0.5 * float(params["rod_length"])))

    def config(self) -> dict:
        return {"effect": self.name, "rod": self.rod, "position": self.position}
