"""Simulate the T6 under a controller and record a trajectory Dataset (docs/data-format.md).

The robot is built at θ, settled for ``settle`` seconds with its motors holding (drop onto a
face and come to rest), then run for ``duration`` seconds. Every ``1/sample_rate`` seconds the
controller is asked for targets, which are held until the next sample (zero-order hold), and
nodes, controls, rest-length readings and tensions are recorded. Settled states are cached per
(θ, options, settle) in this process: settling costs as much as 2 s of simulation.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import xarray as xr

from physics.controllers import Controller, HoldController
from physics.effects.base import Effect, model_space
from physics.errors import ParameterError
from physics.parameters import ParameterSpace
from physics.predictor import step_options
from physics.tensegrity import ModelOptions, RobotState, T6Model
from physics.trajectory import make_trajectory

__all__ = ["simulate", "settled_model"]

_SETTLED: dict[tuple, RobotState] = {}
_CACHE_SIZE = 64


def settled_model(theta: np.ndarray | Mapping[str, float] | None = None, *, space: ParameterSpace | None = None,
                  options: ModelOptions | None = None, settle: float = 2.0,
                  effects: tuple[Effect, ...] = ()) -> T6Model:
    """A :class:`T6Model` at θ (with ``effects``) after ``settle`` seconds of resting (cached per process)."""
    model = T6Model(theta, space=space, options=options, effects=effects)
    if settle < 0 or not np.isfinite(settle):
        raise ParameterError(f"settle must be a duration >= 0 s, got {settle!r}.")
    key = (model.theta.tobytes(), model.options, float(settle), tuple(e.config().__repr__() for e in model.effects))
    state = _SETTLED.get(key)
    if state is None:
        model.settle(settle)
        state = model.get_state()
        if len(_SETTLED) >= _CACHE_SIZE:
            _SETTLED.pop(next(iter(_SETTLED)))
        _SETTLED[key] = state
    model.set_state(state)
    model.world.setTime(0.0)
    return model


def simulate(theta: np.ndarray | Mapping[str, float] | None = None, *, controller: Controller | None = None,
             duration: float = 3.0, sample_rate: float = 100.0, settle: float = 2.0,
             options: ModelOptions | None = None, space: ParameterSpace | None = None,
             noise: float = 0.0, seed: int | np.random.Generator | None = None,
             record_velocities: bool = True, check_bounds: bool = False,
             effects: tuple[Effect, ...] | list[Effect] = (), length_reference: str = "encoder") -> xr.Dataset:
    """Simulate and return a trajectory Dataset with ``nodes``, ``controls``, ``rest_length``, ``tension``.

    duration [s] after settling; sample_rate [Hz] of the recording and the controls; noise: standard
    deviation [m] of Gaussian noise added to the recorded node positions (needs ``seed``; a noisy
    recording has no ``velocities``, like motion capture); record_velocities: store the exact node
    velocities (``velocities`` variable) so the one-step error need not estimate them;
    effects: physics.effects parts the simulated robot has (θ then lives in ``model_space(effects)``;
    the recording does not name them, so data with an undeclared effect are made this way);
    length_reference: record controls and rest lengths as encoder readings (``"encoder"``) or
    true rest lengths (``"true"``); options: model options, whose dt must divide 1/sample_rate
    (:class:`StepSizeError` otherwise); default ModelOptions() with the largest dt <= 1 ms that
    does, dt = Δ / ceil(Δ / 1 ms) for Δ = 1/sample_rate (physics.predictor.physics_step), so any
    rate runs. Raises :class:`PhysicsError` if the simulation diverges.
    """
    effects = tuple(effects)
    space = space or model_space(effects)
    if length_reference not in ("encoder", "true"):
        raise ParameterError(f"length_reference must be 'encoder' or 'true', got {length_reference!r}.")
    theta_arr = space.as_array(theta, check_bounds=check_bounds)
    _check_recording(duration, sample_rate, noise, seed)
    options = step_options(1.0 / sample_rate, options, what=f"sample_rate {sample_rate:g} Hz")
    model = settled_model(theta_arr, space=space, options=options, settle=settle, effects=effects)
    dt = model.options.dt
    substeps = int(round(1.0 / (sample_rate * dt)))
    n = int(round(duration * sample_rate)) + 1
    controller = controller if controller is not None else HoldController()
    nodes, velocities, controls, rest, tension = _record(model, controller, n, sample_rate, substeps)
    if length_reference == "true":
        controls, rest = controls + model.encoder_offset, rest + model.encoder_offset
    if noise > 0:
        nodes = nodes + np.random.default_rng(seed).normal(0.0, noise, nodes.shape)
    # a noisy recording carries positions only (motion capture)
    recorded = velocities if record_velocities and noise <= 0 else None
    attrs = {
        "source": "tensegrid.physics.simulation",
        "physics_dt": dt,
        "settle_s": float(settle),
        "noise_m": float(noise),
        "controller": type(controller).__name__,
        "length_reference": length_reference,
    }
    return make_trajectory(np.arange(n) / sample_rate, nodes, controls, velocities=recorded,
                           rest_length=rest, tension=tension,
                           theta=theta_arr, parameter_names=space.names, attrs=attrs)


def _check_recording(duration: float, sample_rate: float, noise: float,
                     seed: int | np.random.Generator | None) -> None:
    """Raise :class:`ParameterError` for a duration or rate that is not > 0, a negative noise, or
    noise without a seed."""
    if not (np.isfinite(duration) and duration > 0):
        raise ParameterError(f"duration must be > 0 s, got {duration!r}.")
    if not (np.isfinite(sample_rate) and sample_rate > 0):
        raise ParameterError(f"sample_rate must be > 0 Hz, got {sample_rate!r}.")
    if noise < 0 or not np.isfinite(noise):
        raise ParameterError(f"noise must be a standard deviation >= 0 m, got {noise!r}.")
    if noise > 0 and seed is None:
        raise ParameterError("noise > 0 needs an explicit seed (an int or numpy Generator) so results repeat.")


def _record(model: T6Model, controller: Controller, n: int, sample_rate: float,
            substeps: int) -> tuple[np.ndarray, ...]:
    """Run ``controller`` on ``model`` for n samples at ``sample_rate`` [Hz], ``substeps`` physics
    steps apart; returns observed nodes (n, 12, 3) [m], velocities (n, 12, 3) [m/s], controls,
    rest-length readings and tensions (n, 24) [m, m, N]. The model's step raises
    :class:`PhysicsError` if the simulation diverges."""
    controller.reset(model)
    nodes, velocities = np.empty((n, 12, 3)), np.empty((n, 12, 3))
    controls, rest, tension = np.empty((n, 24)), np.empty((n, 24)), np.empty((n, 24))
    for i in range(n):
        nodes[i] = model.observe(model.node_positions())
        velocities[i] = model.node_velocities()
        rest[i] = model.rest_length_readings()
        tension[i] = model.tensions()
        controls[i] = controller(i / sample_rate, model)
        if i < n - 1:
            model.step(controls[i], n=substeps)
    return nodes, velocities, controls, rest, tension
