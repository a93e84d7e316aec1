"""physics.effects: physical effects as composable parts of the T6 model (base: the contract;
world, forces, components, sensing: the catalog; actuation, anchors, fixed_anchors, contact:
components of the mismatch stage and the actuator read from the encoders; catalog: all of them by name)."""
from physics.effects.actuation import MOTOR_PARAMETERS, MeasuredActuator, TensionLimitedActuation
from physics.effects.anchors import CableAnchors
from physics.effects.base import Effect, ForceTerm, ModelSetup, WrenchTerm, model_space, split_theta
from physics.effects.catalog import EFFECT_TYPES, catalog, effect_from_config
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

__all__ = ["Effect", "ForceTerm", "WrenchTerm", "ModelSetup", "model_space", "split_theta", "EFFECT_TYPES", "catalog",
           "effect_from_config", "ActuatorDelay", "EncoderOffset", "CableHysteresis", "NonlinearStiffness",
           "RateLimitedActuation", "TensionLimitedActuation", "MeasuredActuator", "MOTOR_PARAMETERS", "CableAnchors",
           "FixedCableAnchors",
           "AirDrag", "ViscousDrag", "GroundViscosity", "RollingResistance", "SensorBias", "EndCapRadius",
           "CylinderCaps", "GroundSlope", "PointMass"]
