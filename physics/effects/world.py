"""Effects on the world's setup: a tilted ground, the end caps' contact radius, a point mass on a rod."""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from physics.effects.base import Effect, ModelSetup
from physics.errors import ParameterError
from physics.parameters import Parameter

__all__ = ["GroundSlope", "EndCapRadius", "PointMass"]


class GroundSlope(Effect):
    """The ground descends by ``slope_x`` along +x and ``slope_y`` along +y [rad].

    In the ground's frame (the frame of the observations, z normal to the ground) gravity tilts:
    g⃗ = g (sin slope_x, sin slope_y, -sqrt(1 - sin² slope_x - sin² slope_y))."""

    name = "ground_slope"
    description = "ground tilted about the x and y axes"

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter("slope_x", "rad", 0.0, -0.15, 0.15, "ground descends along +x", minimum=-np.inf),
                Parameter("slope_y", "rad", 0.0, -0.15, 0.15, "ground descends along +y", minimum=-np.inf))

    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        g = float(np.linalg.norm(setup.gravity))
        sx, sy = np.sin(values["slope_x"]), np.sin(values["slope_y"])
        setup.gravity = g * np.array([sx, sy, -np.sqrt(max(0.0, 1.0 - sx * sx - sy * sy))])


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
