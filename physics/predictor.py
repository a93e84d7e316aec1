"""The one-step predictor f(x_i, u_i, θ) of the paper's equation (1), and k-step rollouts.

The observed state at sample i is rebuilt in the simulator:

- rod poses from the node positions and rod velocities from the recorded node velocities when
  the data has them (``velocities``, positions then as recorded), else both estimated by a
  :class:`physics.state_estimation.StateEstimator` from samples the prediction is not compared
  with (default: a local quadratic through 4 samples up to x_i and 4 after x_{i+1}), so the noise
  of x_{i+1} never enters the state it is compared with and the state's own noise is small
  (an errors-in-variables bias otherwise moves the minimum of E; that module says why);
- actuator state (rest lengths L0 and spool speeds ω): from the data's ``rest_length`` readings
  (L0 = reading + encoder offset(θ), ω from the backward difference of L0 over r), or, when the
  data has none, reconstructed by running the model's actuator along the observed cable lengths
  (:func:`reconstruct_actuators`);
- commands: the data's attribute ``length_reference`` says whether ``controls`` and
  ``rest_length`` are encoder readings zeroed at the nominal design (``"encoder"``, the default)
  or true rest lengths (``"true"``); with a command delay τ (physics.effects.ActuatorDelay) the
  commands of the last τ seconds are still on their way and are loaded into the model's delay line.

Then the controls u_i are held for one observation interval Δ (``Δ / dt`` physics steps, a whole
number: :func:`physics_step` chooses dt to divide Δ) and the node positions are read:
f(x_i, u_i, θ) = x̂_{i+1}. Observations pass through the model's observation transform
(physics.effects.SensorBias): the state is rebuilt from unobserve(x_i) and the prediction is observe(x̂).
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import xarray as xr

from physics.errors import StepSizeError, TrajectoryFormatError
from physics.geometry import CABLE_NODES
from physics.state_estimation import DEFAULT_STATES, StateEstimator
from physics.tensegrity import ModelOptions, T6Model

__all__ = ["ObservedStates", "LENGTH_REFERENCES", "reconstruct_actuators", "actuator_states", "set_observed_state",
           "predict", "held_commands", "physics_step", "step_options", "dt_option"]

#: What ``controls`` and ``rest_length`` mean: encoder readings zeroed at the nominal design, or true rest lengths.
LENGTH_REFERENCES = ("encoder", "true")
#: Relative slack in "Δ / dt is a whole number", for the rounding of Δ written as decimal seconds.
_WHOLE = 1e-6


def physics_step(interval: float, dt_max: float = ModelOptions.dt) -> float:
    """The largest physics step dt <= dt_max [s] that divides the sample interval Δ [s] into whole steps:

        n = ceil(Δ / dt_max),   dt = Δ / n

    (100 Hz: 10 steps of 1 ms; 120 Hz: 9 of 0.926 ms; 200 Hz: 5 of 1 ms; 240 Hz: 5 of 0.833 ms).
    dt_max (ModelOptions' default dt) bounds the integration error, so no step is longer; dt_max
    itself is returned when it divides Δ within _WHOLE, so 100 Hz data keep exactly the default."""
    ratio = interval / dt_max
    n = max(1, math.ceil(ratio - _WHOLE * ratio))
    return dt_max if abs(n - ratio) <= _WHOLE * ratio else interval / n


def step_options(interval: float, options: ModelOptions | None = None, *, what: str = "the data") -> ModelOptions:
    """Model options whose dt divides the sample interval Δ [s] of ``what``: ModelOptions(dt=physics_step(Δ))
    when ``options`` is None, else ``options`` themselves once checked (:class:`StepSizeError` if Δ / dt is
    not a whole number of steps)."""
    if options is None:
        return ModelOptions(dt=physics_step(interval))
    steps = interval / options.dt
    if round(steps) < 1 or abs(steps - round(steps)) > _WHOLE * max(1.0, steps):
        raise StepSizeError(
            f"{what}: the sampling interval {interval:.6g} s is not a whole number of physics steps dt = "
            f"{options.dt:.6g} s ({steps:.4g} steps); use dt = interval / n for a whole n, e.g. "
            f"{physics_step(interval, options.dt):.6g} s, or leave dt unset to have it chosen so.")
    return options


def dt_option(dt: float | None, datasets: Sequence[xr.Dataset], *, name: str = "dt",
              options: ModelOptions | None = None) -> ModelOptions | None:
    """``options`` (default ModelOptions()) with the physics step ``dt`` [s] given by the user (``name`` in
    messages, e.g. ``--dt``), checked against every trajectory's sample interval; ``options`` unchanged
    when dt is None (the step is then chosen per trajectory, :func:`physics_step`). Raises
    :class:`StepSizeError` if dt is not in (0, 0.01] s or does not divide an interval."""
    if dt is None:
        return options
    if not (math.isfinite(dt) and 0 < dt <= 0.01):
        raise StepSizeError(f"{name} must be a physics step in (0, 0.01] s, got {dt!r}; leave it out to have "
                            "it chosen from the sampling interval.")
    chosen = dataclasses.replace(options or ModelOptions(), dt=float(dt))
    for k, ds in enumerate(datasets):
        time = np.asarray(ds["time"].values, dtype=float)
        step_options(float(time[1] - time[0]), chosen, what=f"{name} {dt:g} s on trajectory {k}")
    return chosen


class ObservedStates:
    """Arrays derived from one trajectory: times (T,), nodes (T x 12 x 3, as recorded: what
    predictions are compared with), the states predictions start from, ``state_nodes`` and node
    ``velocities`` (T x 12 x 3 each, NaN where not estimable: recorded, else by ``states`` leaving
    out the ``ahead`` samples each prediction is compared with, None for a free rollout), controls
    (T x 24), readings (T x 24 or None), Δ [s], ``reference`` (one of LENGTH_REFERENCES) and
    ``valid`` (T,) = the state at i can be rebuilt."""

    def __init__(self, ds: xr.Dataset, *, states: StateEstimator = DEFAULT_STATES, ahead: int | None = 1) -> None:
        self.reference = str(ds.attrs.get("length_reference", "encoder"))
        if self.reference not in LENGTH_REFERENCES:
            raise TrajectoryFormatError(f"attribute length_reference must be one of {LENGTH_REFERENCES}, got "
                                        f"{self.reference!r} (docs/data-format.md).")
        self.times = np.asarray(ds["time"].values, float)
        self.interval = float(self.times[1] - self.times[0])
        self.nodes = np.asarray(ds["nodes"].transpose("time", "node", "axis").values, float)
        self.controls = np.asarray(ds["controls"].transpose("time", "cable").values, float)
        self.readings = (np.asarray(ds["rest_length"].transpose("time", "cable").values, float)
                         if "rest_length" in ds else None)
        x = self.nodes
        if "velocities" in ds:
            self.state_nodes = x
            vel = np.asarray(ds["velocities"].transpose("time", "node", "axis").values, float)
        else:
            self.state_nodes, vel = states.estimate(x, self.interval, ahead=ahead)
        self.velocities = vel
        finite_x = np.isfinite(x).all(axis=(1, 2))
        finite_state = finite_x & np.isfinite(self.state_nodes).all(axis=(1, 2))
        finite_u = np.isfinite(self.controls).all(axis=1)
        self.valid = finite_state & np.isfinite(vel).all(axis=(1, 2)) & finite_u
        if self.readings is not None:
            self.valid &= np.isfinite(self.readings).all(axis=1)
        self.finite = finite_x


def _offset(obs: ObservedStates, model: T6Model) -> np.ndarray:
    """Offset from the data's lengths to true rest lengths (24,) [m]: θ's encoder offset (or 0 for
    true lengths) plus the model's command offset."""
    base = model.encoder_offset if obs.reference == "encoder" else np.zeros_like(model.encoder_offset)
    return base + model.setup.command_offset


def _delayed_targets(obs: ObservedStates, model: T6Model, controls: np.ndarray, times: np.ndarray) -> np.ndarray:
    """True targets (len(times) x 24) the actuators see at ``times``: the latest command sent at or
    before t - τ (zero-order hold), or the build rest lengths before the first one."""
    index = np.searchsorted(obs.times, times - model.setup.command_delay + 1e-9, side="right") - 1
    out = np.where(index[:, None] >= 0, controls[np.maximum(index, 0)] + _offset(obs, model), model.build_rest_length)
    return out


def reconstruct_actuators(obs: ObservedStates, model: T6Model) -> tuple[np.ndarray, np.ndarray]:
    """Rest lengths and actuator speeds (T x 24 each) of θ's actuator driven along the observed motion.

    Starts from the build rest lengths of θ (the robot held them while settling); per physics step
    the tension comes from the observed cable lengths (linear between samples, rates constant per
    interval) through physics.cables.cable_tension, and the targets from the (delayed) controls.
    Samples with missing nodes are filled by linear interpolation in time.
    """
    nodes = obs.nodes
    if not obs.finite.all():
        t = obs.times
        good = obs.finite
        nodes = np.stack([np.stack([np.interp(t, t[good], nodes[good, n, a]) for a in range(3)], -1)
                          for n in range(12)], 1)
    lengths = np.linalg.norm(nodes[:, CABLE_NODES[:, 1]] - nodes[:, CABLE_NODES[:, 0]], axis=2)
    rates = np.zeros_like(lengths)
    rates[:-1] = np.diff(lengths, axis=0) / obs.interval
    controls = obs.controls.copy()
    bad = ~np.isfinite(controls)
    if bad.any():  # hold the last finite command; before the first one, the build rest length
        for i in range(len(controls)):
            previous = controls[i - 1] if i else model.build_rest_length - _offset(obs, model)
            controls[i, bad[i]] = previous[bad[i]]
    dt = model.options.dt
    substeps = int(round(obs.interval / dt))
    step_times = obs.times[0] + dt * np.arange(substeps * (len(lengths) - 1))
    targets = _delayed_targets(obs, model, controls, step_times)
    return model.setup.actuator.follow(lengths, rates, np.ascontiguousarray(targets), model.build_rest_length,
                                       substeps, tuple(float(v) for v in model.setup.cable.args()))


def actuator_states(obs: ObservedStates, model: T6Model, source: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """True rest lengths and spool speeds (T x 24) at every sample, from data or reconstructed."""
    if source not in ("auto", "measured", "reconstructed"):
        from physics.errors import ParameterError
        raise ParameterError(f"actuators must be 'auto', 'measured' or 'reconstructed', got {source!r}.")
    if source == "measured" or (source == "auto" and obs.readings is not None):
        if obs.readings is None:
            raise TrajectoryFormatError("actuators='measured' needs a 'rest_length' variable in the data; "
                                        "use actuators='reconstructed' or 'auto'.")
        rest = obs.readings + _offset(obs, model)
        speed = np.zeros_like(rest)
        speed[1:] = model.setup.actuator.speed_from_rest(np.diff(rest, axis=0) / obs.interval)
        speed[~np.isfinite(speed)] = 0.0
        return rest, speed
    return reconstruct_actuators(obs, model)


def set_observed_state(model: T6Model, obs: ObservedStates, start: int, rest: np.ndarray, speed: np.ndarray) -> None:
    """Put the simulator in the observed state at sample ``start``: rods at the state's nodes (through
    the model's inverse observation transform) and velocities, actuators at ``rest`` and ``speed``
    (T x 24, :func:`actuator_states`), the clock at the sample's time, and the commands sent in the
    last τ seconds loaded into the delay line (physics.effects.ActuatorDelay)."""
    model.set_nodes(model.unobserve(obs.state_nodes[start]), obs.velocities[start])
    model.rest_length = rest[start].copy()
    model.motor_speed = speed[start].copy()
    model.world.setTime(float(obs.times[start]))
    if model.setup.command_delay > 0:
        first = max(0, int(np.searchsorted(obs.times, obs.times[start] - model.setup.command_delay - 1e-9)) - 1)
        past = slice(first, start)
        ok = np.isfinite(obs.controls[past]).all(axis=1)
        model.prime_commands(obs.times[past][ok], obs.controls[past][ok], obs.reference)


def held_commands(controls: np.ndarray) -> np.ndarray:
    """Controls (T x 24) with each missing command replaced by the last one sent before it (zero-order
    hold: a dropped frame loses the record of a command, not the command); NaN before the first one."""
    out = np.array(controls, dtype=float)
    for i in range(1, len(out)):
        bad = ~np.isfinite(out[i])
        out[i, bad] = out[i - 1, bad]
    return out


def predict(model: T6Model, obs: ObservedStates, start: int, steps: int,
            rest: np.ndarray, speed: np.ndarray, *, controls: np.ndarray | None = None) -> np.ndarray:
    """Predicted node positions (steps x 12 x 3) at samples start+1 .. start+steps.

    The simulator is set to the observed state at ``start`` (:func:`set_observed_state`) and the
    recorded controls (or ``controls``, T x 24, e.g. :func:`held_commands`) are replayed (held per
    interval). Raises PhysicsError if the simulation diverges.
    """
    substeps = int(round(obs.interval / model.options.dt))
    set_observed_state(model, obs, start, rest, speed)
    out = np.empty((steps, 12, 3))
    sent = obs.controls if controls is None else controls
    for k in range(steps):
        model.step(sent[start + k], n=substeps, reference=obs.reference)
        out[k] = model.node_positions()
    return model.observe(out)
