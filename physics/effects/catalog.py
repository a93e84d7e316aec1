"""The catalog of effects criticism tries, and rebuilding an effect from its configuration."""
from __future__ import annotations

from physics.effects.actuation import MeasuredActuator, TensionLimitedActuation
from physics.effects.anchors import CableAnchors
from physics.effects.base import Effect
from physics.effects.components import (
    ActuatorDelay,
    CableHysteresis,
    EncoderOffset,
    NonlinearStiffness,
    RateLimitedActuation,
)
from physics.effects.contact import RollingResistance
from physics.effects.fixed_anchors import FixedCableAnchors
from physics.effects.forces import AirDrag, GroundViscosity, ViscousDrag
from physics.effects.sensing import SensorBias
from physics.effects.world import CylinderCaps, EndCapRadius, GroundSlope, PointMass
from physics.errors import ParameterError

__all__ = ["EFFECT_TYPES", "catalog", "effect_from_config"]

_CATALOG = (GroundSlope, AirDrag, ViscousDrag, GroundViscosity, CableHysteresis, NonlinearStiffness, ActuatorDelay,
            RateLimitedActuation, SensorBias, EndCapRadius, PointMass)

#: Every effect class, by name: the catalog's, then those criticism does not try by default (EncoderOffset;
#: TensionLimitedActuation, CableAnchors, FixedCableAnchors, CylinderCaps and RollingResistance, components of
#: the mismatch stage, criticism.mismatch; MeasuredActuator, read from the encoders).
EFFECT_TYPES: dict[str, type[Effect]] = {cls.name: cls for cls in _CATALOG + (
    EncoderOffset, TensionLimitedActuation, CableAnchors, FixedCableAnchors, CylinderCaps, RollingResistance,
    MeasuredActuator)}


#: Options of the catalog's instances that differ from the classes' defaults: the point mass's rod
#: is the data's to choose (PointMass.placements).
_CATALOG_OPTIONS: dict[type[Effect], dict] = {PointMass: {"rod": None}}


def catalog() -> tuple[Effect, ...]:
    """One instance of every effect criticism tries by default, in a fixed order, with default
    options except ``_CATALOG_OPTIONS``."""
    return tuple(cls(**_CATALOG_OPTIONS.get(cls, {})) for cls in _CATALOG)


def effect_from_config(config: dict) -> Effect:
    """Rebuild an effect from :meth:`Effect.config` (e.g. read back from a saved result)."""
    options = dict(config)
    name = options.pop("effect", None)
    if name not in EFFECT_TYPES:
        raise ParameterError(f"unknown effect {name!r}; known effects are {sorted(EFFECT_TYPES)}.")
    return EFFECT_TYPES[name](**options)
