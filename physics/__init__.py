"""physics: what the world does — parameter spaces, the DART SUPERball model, its motors and
controllers, trajectories (xarray), the trajectory error E(θ), the objective contract, the dask
pool, the 1-D push toy, and what the user measured or fixed (physics.measurements, physics.fixed).

Knows nothing of GPs or embeddings (the arrows point planners -> belief -> embeddings -> physics).

Public names are re-exported lazily (PEP 562): ``from physics import TrajectoryObjective`` imports
:mod:`physics.trajectory_objective` on first use, so ``import physics.parameters`` (and thereby ``belief`` and
``embeddings``) does not load dartpy or compile the numba kernels.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from physics.actuators import MotorGains
    from physics.controllers import Controller, FlopController, FlopPlan, HoldController, ReplayController
    from physics.errors import (
        ContractError,
        ControllerError,
        MeasurementError,
        NoResidualsError,
        ParameterError,
        PhysicsError,
        PoolError,
        TensegridError,
        TrajectoryFormatError,
    )
    from physics.fixed import FixedParameters
    from physics.geometry import (
        CABLE_NAMES,
        CABLE_NODES,
        ROD_NODES,
        closed_faces,
        node_positions,
        rod_mass_properties,
    )
    from physics.measurements import (
        Measurement,
        MeasurementPrior,
        check_measurements,
        measured_values,
        parse_fixed,
        parse_measurement,
    )
    from physics.objective import STATUSES, BatchResult, FunctionObjective, Objective, as_objective
    from physics.parameters import T6_NOMINAL, Parameter, ParameterSpace
    from physics.pool import DaskPool
    from physics.predictor import ObservedStates, predict, reconstruct_actuators
    from physics.push import PushObjective, generate_push_data, push_space, simulate_push
    from physics.simulation import settled_model, simulate
    from physics.state_estimation import StateEstimator
    from physics.tensegrity import ModelOptions, RobotState, T6Model, rod_poses_from_nodes
    from physics.trajectory import (
        describe_trajectory,
        load_trajectory,
        make_trajectory,
        save_trajectory,
        validate_trajectory,
    )
    from physics.trajectory_objective import TrajectoryObjective

_EXPORTS: dict[str, tuple[str, ...]] = {
    "physics.errors": ("TensegridError", "ParameterError", "PhysicsError", "TrajectoryFormatError",
                       "ControllerError", "PoolError", "ContractError", "NoResidualsError", "MeasurementError"),
    "physics.parameters": ("Parameter", "ParameterSpace", "T6_NOMINAL"),
    "physics.geometry": ("CABLE_NAMES", "CABLE_NODES", "ROD_NODES", "closed_faces", "node_positions",
                         "rod_mass_properties"),
    "physics.actuators": ("MotorGains",),
    "physics.tensegrity": ("ModelOptions", "RobotState", "T6Model", "rod_poses_from_nodes"),
    "physics.controllers": ("Controller", "FlopController", "FlopPlan", "HoldController", "ReplayController"),
    "physics.trajectory": ("make_trajectory", "validate_trajectory", "save_trajectory", "load_trajectory",
                           "describe_trajectory"),
    "physics.simulation": ("simulate", "settled_model"),
    "physics.state_estimation": ("StateEstimator",),
    "physics.predictor": ("ObservedStates", "predict", "reconstruct_actuators"),
    "physics.objective": ("STATUSES", "BatchResult", "Objective", "FunctionObjective", "as_objective"),
    "physics.pool": ("DaskPool",),
    "physics.trajectory_objective": ("TrajectoryObjective",),
    "physics.push": ("PushObjective", "generate_push_data", "push_space", "simulate_push"),
    "physics.measurements": ("Measurement", "MeasurementPrior", "parse_measurement", "parse_fixed",
                             "check_measurements", "measured_values"),
    "physics.fixed": ("FixedParameters",),
}
_ORIGIN = {name: module for module, names in _EXPORTS.items() for name in names}

# Spelled out (not derived from _EXPORTS) so linters and type checkers see the public names;
# tests/physics/test_imports.py checks that the two lists agree.
__all__ = [
    "TensegridError", "ParameterError", "PhysicsError", "TrajectoryFormatError", "ControllerError", "PoolError",
    "ContractError", "NoResidualsError", "MeasurementError",
    "Parameter", "ParameterSpace", "T6_NOMINAL",
    "CABLE_NAMES", "CABLE_NODES", "ROD_NODES", "closed_faces", "node_positions", "rod_mass_properties",
    "MotorGains",
    "ModelOptions", "RobotState", "T6Model", "rod_poses_from_nodes", "StateEstimator",
    "Controller", "FlopController", "FlopPlan", "HoldController", "ReplayController",
    "make_trajectory", "validate_trajectory", "save_trajectory", "load_trajectory", "describe_trajectory",
    "simulate", "settled_model",
    "ObservedStates", "predict", "reconstruct_actuators",
    "STATUSES", "BatchResult", "Objective", "FunctionObjective", "as_objective",
    "DaskPool",
    "TrajectoryObjective",
    "PushObjective", "generate_push_data", "push_space", "simulate_push",
    "Measurement", "MeasurementPrior", "parse_measurement", "parse_fixed", "check_measurements", "measured_values",
    "FixedParameters",
]


def __getattr__(name: str) -> Any:
    """Import the module that defines a public name on first access (PEP 562) and cache the name."""
    module = _ORIGIN.get(name)
    if module is None:
        raise AttributeError(f"module 'physics' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
