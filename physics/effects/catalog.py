"""The catalog of effects criticism tries, and rebuilding an effect from its configuration."""
from __future__ import annotations

from physics.effects.base import Effect
from physics.effects.components import ActuatorDelay, CableHysteresis, NonlinearStiffness, RateLimitedActuation
from physics.effects.forces import AirDrag, GroundViscosity
from physics.effects.sensing import SensorBias
from physics.effects.world import EndCapRadius, GroundSlope, PointMass
from physics.errors import ParameterError

__all__ = ["EFFECT_TYPES", "catalog", "effect_from_config"]

#: Every effect class, by name.
EFFECT_TYPES: dict[str, type[Effect]] = {cls.name: cls for cls in (
    GroundSlope, AirDrag, GroundViscosity, CableHysteresis, NonlinearStiffness, ActuatorDelay,
    RateLimitedActuation, SensorBias, EndCapRadius, PointMass)}


def catalog() -> tuple[Effect, ...]:
    """One instance of every effect with its default options, in a fixed order."""
    return tuple(cls() for cls in EFFECT_TYPES.values())


def effect_from_config(config: dict) -> Effect:
    """Rebuild an effect from :meth:`Effect.config` (e.g. read back from a saved result)."""
    options = dict(config)
    name = options.pop("effect", None)
    if name not in EFFECT_TYPES:
        raise ParameterError(f"unknown effect {name!r}; known effects are {sorted(EFFECT_TYPES)}.")
    return EFFECT_TYPES[name](**options)
