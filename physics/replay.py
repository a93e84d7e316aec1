"""Replay a recording in the simulator: start where the recording starts, send its commands, compare.

:func:`replay` builds the T6 at θ (with effects), puts it in the recording's state at its first
sample whose state can be rebuilt (in a recording that starts complete, the first), and sends the
recorded controls, each held for one sample interval, until the recording ends (or ``duration``
runs out). Nothing is fed back: the result is the open-loop rollout the identification's
"trajectory error" plots, recorded as a trajectory (nodes, velocities, rest-length readings,
tensions) on the recording's clock.

The starting state is the one :func:`physics.predictor.set_observed_state` rebuilds:

- rods from the node positions; their velocities from the recording's ``velocities`` when it has
  them, else estimated by ``states`` from the positions around the start, none left out: a replay
  is compared with the recording, not minimized, so the samples the state uses bias no estimate.
  The default, :data:`REPLAY_STATES`, is the quadratic least-squares fit through the samples from 9
  before to 10 after the start (at the first sample: it and the 10 after it), its value and slope
  there the state. At the edge of a recording a fit is one-sided, and there the objective's cubic
  through 7 samples multiplies the noise into the velocity: on 1 mm noise its replays of a flop at
  θ* drift 3-10 mm by 0.3 s, the quadratic's 1-2 mm, also when the replay starts mid-flop;
- actuators from the recording's ``rest_length`` readings when it has them (the spool speed from
  the readings' change over the interval before the start, or at the first sample the one after it),
  else from θ's motor model run along the observed cable lengths from θ's build rest lengths
  (physics.predictor.actuator_states): such a recording should start with the motors at rest.

Before anything is simulated the recording's rods are measured against θ: a rod whose median length
is more than :data:`~physics.checks_robot.ROD_TOLERANCE` off θ's ``rod_length`` means the nodes
belong to another robot or are mislabelled, and the rods could not be placed on them.

The open-loop error at time a after the start is the RMS node distance between rollout and
recording at that sample, sqrt(mean over the 12 nodes of ||x_n - x̂_n||²) [m].
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import xarray as xr

from physics.checks_robot import ROD_TOLERANCE
from physics.effects.base import Effect, model_space
from physics.errors import ParameterError, TrajectoryFormatError
from physics.labels import pair_distances, rod_lengths
from physics.predictor import ObservedStates, actuator_states, held_commands, set_observed_state, step_options
from physics.state_estimation import StateEstimator
from physics.tensegrity import ModelOptions, T6Model
from physics.trajectory import make_trajectory, regular_clock, validate_trajectory

__all__ = ["Replay", "replay", "check_rods", "rms_node_distance", "OPEN_LOOP_TIMES", "REPLAY_STATES"]

#: The times after the start [s] at which the open-loop error is reported.
OPEN_LOOP_TIMES = (0.3, 0.5, 1.0)
#: How a replay estimates its starting velocities from positions (module docstring).
REPLAY_STATES = StateEstimator(method="local-polynomial", half_width=10, degree=2)

InitialVelocities = Literal["recorded", "estimated"]


def rms_node_distance(observed: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """sqrt(mean over nodes of ||x_n - x̂_n||²) per sample [m] (T,) of two (T x 12 x 3) arrays, NaN
    where either misses a node."""
    diff = np.asarray(predicted, dtype=float) - np.asarray(observed, dtype=float)
    return np.sqrt(np.mean(np.sum(diff ** 2, axis=2), axis=1))


@dataclass(frozen=True)
class Replay:
    """An open-loop replay: ``rollout`` (the simulated trajectory), ``observed`` (the recording over
    the same samples), ``start`` (the recording's sample both start at) and ``velocities`` (whether
    the starting velocities were ``"recorded"`` or ``"estimated"`` from positions)."""

    rollout: xr.Dataset
    observed: xr.Dataset
    start: int
    velocities: InitialVelocities

    def __post_init__(self) -> None:
        if self.velocities not in ("recorded", "estimated"):
            raise ParameterError(f"Replay.velocities must be 'recorded' or 'estimated', got {self.velocities!r}.")
        if self.start < 0:
            raise ParameterError(f"Replay.start must be a sample index >= 0, got {self.start!r}.")
        if not np.array_equal(self.rollout["time"].values, self.observed["time"].values):
            raise ParameterError("Replay: the rollout and the observed trajectory must share their time samples.")

    @property
    def duration(self) -> float:
        """Seconds the replay covers [s]."""
        time = self.rollout["time"].values
        return float(time[-1] - time[0])

    def distance(self) -> np.ndarray:
        """The RMS node distance between rollout and recording at every sample [m] (T,), NaN where a
        recorded node is missing."""
        return rms_node_distance(self.observed["nodes"].transpose("time", "node", "axis").values,
                                 self.rollout["nodes"].transpose("time", "node", "axis").values)

    def errors(self, at: Sequence[float] = OPEN_LOOP_TIMES) -> dict[float, float]:
        """The open-loop error [m] at each time ``at`` [s] after the start (the nearest sample); NaN
        past the replay's end or where the recording misses a node there."""
        time = self.rollout["time"].values
        distance = self.distance()
        out = {}
        for a in at:
            k = int(round(float(a) / float(time[1] - time[0])))
            out[float(a)] = float(distance[k]) if 0 <= k < len(time) else float("nan")
        return out


def check_rods(recording: xr.Dataset, rod_length: float) -> None:
    """Raise :class:`TrajectoryFormatError` when a rod of ``recording`` (median length over time) is
    more than ROD_TOLERANCE off ``rod_length`` [m] (module docstring)."""
    nodes = np.asarray(recording["nodes"].transpose("time", "node", "axis").values, float)
    rods = rod_lengths(pair_distances(nodes)[0])
    off = [i for i in range(6) if not abs(rods[i] - rod_length) <= ROD_TOLERANCE]
    if off:
        listed = ", ".join(f"rod {i} (nodes {2 * i}-{2 * i + 1}) {rods[i]:.3f} m" for i in off)
        raise TrajectoryFormatError(
            f"the recording's nodes do not match the model: {listed}, while θ's rod_length is {rod_length:.3f} m "
            f"(more than {ROD_TOLERANCE} m apart); the recording is of another robot, its node labels are "
            "swapped (tensegrid check says which) or rod_length should be what the rods measure.")


def _samples(obs: ObservedStates, duration: float | None) -> tuple[int, int]:
    """(start, n): the first sample whose state can be rebuilt and how many samples the replay records."""
    starts = np.flatnonzero(obs.valid)
    if starts.size == 0:
        raise TrajectoryFormatError("the recording has no sample with a complete state (nodes, velocities or "
                                    "enough samples to estimate them, controls) to start a replay from.")
    start = int(starts[0])
    n = len(obs.times) - start
    if duration is not None:
        if not (np.isfinite(duration) and duration > 0):
            raise ParameterError(f"duration must be > 0 s, got {duration!r}.")
        n = min(n, int(round(duration / obs.interval)) + 1)
    if n < 2:
        raise TrajectoryFormatError(f"the recording ends at its sample {start}, the first with a complete state: "
                                    "nothing to replay.")
    return start, n


def _run(model: T6Model, controls: np.ndarray, substeps: int, reference: str) -> tuple[np.ndarray, ...]:
    """Record the model's observed nodes and node velocities (n x 12 x 3), rest-length readings (in
    ``reference``) and tensions (n x 24) at each of the n samples, sending ``controls`` (n x 24)
    between them."""
    n = len(controls)
    nodes, velocities = np.empty((n, 12, 3)), np.empty((n, 12, 3))
    readings, tension = np.empty((n, 24)), np.empty((n, 24))
    for k in range(n):
        nodes[k] = model.observe(model.node_positions())
        velocities[k] = model.node_velocities()
        readings[k] = model.rest_length_readings() + (model.encoder_offset if reference == "true" else 0.0)
        tension[k] = model.tensions()
        if k < n - 1:
            model.step(controls[k], n=substeps, reference=reference)
    return nodes, velocities, readings, tension


def replay(recording: xr.Dataset, theta: np.ndarray | Mapping[str, float] | None = None, *,
           effects: Sequence[Effect] = (), duration: float | None = None, options: ModelOptions | None = None,
           states: StateEstimator = REPLAY_STATES) -> Replay:
    """The open-loop replay of ``recording`` at θ (module docstring).

    effects: physics.effects parts of the model (θ lives in ``model_space(effects)``; a mapping may
    leave names out, which take the nominal value); duration: seconds to replay at most (default:
    to the recording's end); options: model options whose dt divides the sample interval (default:
    the largest dt <= 1 ms that does); states: how starting velocities are estimated when the
    recording has none. Raises :class:`TrajectoryFormatError` before simulating when the recording's
    rods do not match θ or no sample can start a replay, :class:`PhysicsError` if the simulation diverges.
    """
    effects = tuple(effects)
    space = model_space(effects)
    theta_arr = space.as_array(theta, check_bounds=False)
    if not isinstance(states, StateEstimator):
        raise ParameterError(f"states must be a physics.StateEstimator, got {type(states).__name__}.")
    recording = validate_trajectory(regular_clock(recording))
    check_rods(recording, float(theta_arr[space.names.index("rod_length")]))
    obs = ObservedStates(recording, states=states, ahead=0)
    start, n = _samples(obs, duration)
    options = step_options(obs.interval, options, what="the recording")
    model = T6Model(theta_arr, space=space, options=options, effects=effects)
    rest, speed = actuator_states(obs, model, "auto")
    if obs.readings is not None and start == 0:
        speed[0] = speed[1]         # no reading before the first: the spool speed of the first interval
    set_observed_state(model, obs, start, rest, speed)
    controls = held_commands(obs.controls[start:start + n])     # the first is finite: a valid start
    substeps = int(round(obs.interval / model.options.dt))
    nodes, velocities, readings, tension = _run(model, controls, substeps, obs.reference)
    velocity_source: InitialVelocities = "recorded" if "velocities" in recording else "estimated"
    attrs = {"source": "tensegrid.physics.replay", "physics_dt": model.options.dt, "controller": "replay",
             "length_reference": obs.reference, "start_sample": start,
             "initial_velocities": velocity_source}
    rollout = make_trajectory(obs.times[start:start + n], nodes, controls, velocities=velocities,
                              rest_length=readings, tension=tension, theta=theta_arr,
                              parameter_names=space.names, attrs=attrs)
    observed = recording.isel(time=slice(start, start + n))
    return Replay(rollout=rollout, observed=observed, start=start, velocities=velocity_source)
