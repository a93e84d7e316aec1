"""physics: what the world does — parameter spaces, the DART SUPERball model, its motors and
controllers, trajectories (xarray), the trajectory error E(θ), and the 1-D push toy.

Knows nothing of GPs or embeddings (the arrows point planners -> belief -> embeddings -> physics).
"""
from __future__ import annotations

from physics.errors import (
    ControllerError, ParameterError, PhysicsError, TensegridError, TrajectoryFormatError,
)
from physics.parameters import T6_NOMINAL, Parameter, ParameterSpace
from physics.geometry import CABLE_NAMES, CABLE_NODES, ROD_NODES, closed_faces, node_positions, rod_mass_properties
from physics.actuators import MotorGains
from physics.tensegrity import ModelOptions, RobotState, T6Model, rod_poses_from_nodes
from physics.controllers import Controller, FlopController, FlopPlan, HoldController, ReplayController
from physics.trajectory import load_trajectory, make_trajectory, save_trajectory, validate_trajectory
from physics.simulate import settled_model, simulate
from physics.predictor import ObservedStates, predict, reconstruct_actuators
from physics.error import BatchResult, TrajectoryError
from physics.push import PushError, generate_push_data, push_space, simulate_push

__all__ = [
    "TensegridError", "ParameterError", "PhysicsError", "TrajectoryFormatError", "ControllerError",
    "Parameter", "ParameterSpace", "T6_NOMINAL",
    "CABLE_NAMES", "CABLE_NODES", "ROD_NODES", "closed_faces", "node_positions", "rod_mass_properties",
    "MotorGains", "ModelOptions", "RobotState", "T6Model", "rod_poses_from_nodes",
    "Controller", "FlopController", "FlopPlan", "HoldController", "ReplayController",
    "make_trajectory", "validate_trajectory", "save_trajectory", "load_trajectory",
    "simulate", "settled_model",
    "ObservedStates", "predict", "reconstruct_actuators",
    "TrajectoryError", "BatchResult",
    "PushError", "generate_push_data", "push_space", "simulate_push",
]
