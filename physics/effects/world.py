"""Effects on the world's setup: a sloped floor, the end caps' contact radius, a point mass on a rod."""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr

from physics.effects.base import Effect, ModelSetup
from physics.errors import ParameterError
from physics.ground import ground_plane
from physics.parameters import Parameter

__all__ = ["GroundSlope", "slope_normal", "EndCapRadius", "PointMass"]


class GroundSlope(Effect):
    """The floor descends by ``slope_x`` along +x and ``slope_y`` along +y [rad], in the world frame.

    The data contract's frame is the world's (z up, gravity along −z), so a sloped floor is a
    tilted ground plane through the origin, not a tilted gravity: its unit normal is
    n = (sin slope_x, sin slope_y, sqrt(1 − sin² slope_x − sin² slope_y)) and gravity stays −g ẑ.
    The resting robot's contact nodes then lie on a plane with that normal, which the data show
    at rest (physics.ground.ground_plane: slope_x = arcsin n_x, slope_y = arcsin n_y)."""

    name = "ground_slope"
    description = "floor tilted about the x and y axes (world frame, gravity -z)"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("slope_x", "rad", 0.0, -0.15, 0.15, "floor descends along +x", minimum=-np.inf),
                Parameter("slope_y", "rad", 0.0, -0.15, 0.15, "floor descends along +y", minimum=-np.inf))

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        setup.ground_normal = slope_normal(float(values["slope_x"]), float(values["slope_y"]))

    def start(self, trajectories: Sequence[xr.Dataset]) -> dict[str, float]:
        """The slope of the plane the resting robot's contact nodes lie on (physics.ground), median
        over the trajectories that start at rest, clipped to the box; nominal (level) without one."""
        planes = [p for p in (ground_plane(ds) for ds in trajectories) if p is not None]
        if not planes:
            return super().start(trajectories)
        normal = np.median([p.normal for p in planes], axis=0)
        return {q.name: float(np.clip(np.arcsin(v), q.lower, q.upper))
                for q, v in zip(self.parameters(), normal[:2], strict=True)}


def slope_normal(slope_x: float, slope_y: float) -> np.ndarray:
    """Unit normal (3,) of a floor descending by ``slope_x`` along +x and ``slope_y`` along +y [rad]."""
    sx, sy = np.sin(slope_x), np.sin(slope_y)
    return np.array([sx, sy, np.sqrt(max(0.0, 1.0 - sx * sx - sy * sy))])


class EndCapRadius(Effect):
    """The end caps touch the ground with a sphere of radius ``radius + cap_radius_change`` [m]
    instead of ``radius`` (a flatter or smaller cap than the rod's end segment)."""

    name = "end_cap_radius"
    description = "contact radius of the end caps differs from the rod radius"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("cap_radius_change", "m", 0.0, -0.04, 0.03, "contact radius minus rod radius",
                          minimum=-np.inf),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        radius = setup.cap_radius + values["cap_radius_change"]
        if radius < 0.005:
            raise ParameterError(f"cap_radius_change = {values['cap_radius_change']} m leaves a contact radius of "
                                 f"{radius:.4f} m; it must stay >= 0.005 m.")
        setup.cap_radius = radius


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
    length from its centre (toward node 2·rod + 1): a sensor box or battery nobody modelled."""

    name = "point_mass"
    description = "an extra point mass on one rod"

    def __init__(self, rod: int = 0, position: float = 0.6) -> None:
        if rod not in range(6):
            raise ParameterError(f"PointMass.rod must be a rod index in 0..5, got {rod!r}.")
        if not (-1.0 <= position <= 1.0):
            raise ParameterError("PointMass.position must be in [-1, 1] (fraction of the half length), got "
                                 f"{position!r}.")
        self.rod, self.position = int(rod), float(position)

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("point_mass", "kg", 0.0, 0.0, 3.0, "extra mass on one rod", strict=False),)

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        if values["point_mass"] > 0:
            setup.point_masses.append((self.rod, float(values["point_mass"]),
                                       self.position * 0.5 * float(params["rod_length"])))

    def config(self) -> dict:
        return {"effect": self.name, "rod": self.rod, "position": self.position}
