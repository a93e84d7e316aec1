"""The one-step predictor f(x_i, u_i, θ) of the paper's equation (1), and k-step rollouts.

The observed state at sample i is rebuilt in the simulator:

- rod poses from the node positions x_i (12 x 3); rod velocities from the recorded node
  velocities when the data has them (``velocities``), else estimated from the past only,
  v_i ≈ (3 x_i - 4 x_{i-1} + x_{i-2}) / (2 Δ) (second-order backward difference; first order
  when x_{i-2} is missing), so the prediction never sees x_{i+1}. The estimate costs accuracy:
  its error, O(Δ² d³x/dt³), sets a floor under E(θ_true) (docs/physics.md gives the figure);
- actuator state (rest lengths L0 and spool speeds ω): from the data's ``rest_length`` readings
  (L0 = reading + encoder offset(θ), ω from the backward difference of L0 over r), or, when the
  data has none, reconstructed by running the motor model of θ along the observed cable lengths
  (:func:`reconstruct_actuators`).

Then the controls u_i are held for one observation interval Δ (``Δ / dt`` physics steps) and the
node positions are read: f(x_i, u_i, θ) = x̂_{i+1}.
"""
from __future__ import annotations

import numpy as np
import xarray as xr
from numba import njit

from physics.actuators import motor_step
from physics.geometry import CABLE_NODES, N_CABLES
from physics.tensegrity import T6Model

__all__ = ["ObservedStates", "reconstruct_actuators", "actuator_states", "predict"]


class ObservedStates:
    """Arrays derived from one trajectory: times (T,), nodes (T x 12 x 3), node velocities
    (T x 12 x 3, NaN where not estimable), controls (T x 24), readings (T x 24 or None), Δ [s],
    and ``valid`` (T,) = the state at i can be rebuilt."""

    def __init__(self, ds: xr.Dataset) -> None:
        self.times = np.asarray(ds["time"].values, float)
        self.interval = float(self.times[1] - self.times[0])
        self.nodes = np.asarray(ds["nodes"].transpose("time", "node", "axis").values, float)
        self.controls = np.asarray(ds["controls"].transpose("time", "cable").values, float)
        self.readings = (np.asarray(ds["rest_length"].transpose("time", "cable").values, float)
                         if "rest_length" in ds else None)
        x = self.nodes
        if "velocities" in ds:
            vel = np.asarray(ds["velocities"].transpose("time", "node", "axis").values, float)
        else:
            vel = np.full_like(x, np.nan)
            vel[2:] = (3 * x[2:] - 4 * x[1:-1] + x[:-2]) / (2 * self.interval)
            first = (x[1:] - x[:-1]) / self.interval
            fill = ~np.isfinite(vel[1:]).all(axis=(1, 2))
            vel[1:][fill] = first[fill]
        self.velocities = vel
        finite_x = np.isfinite(x).all(axis=(1, 2))
        finite_u = np.isfinite(self.controls).all(axis=1)
        self.valid = finite_x & np.isfinite(vel).all(axis=(1, 2)) & finite_u
        if self.readings is not None:
            self.valid &= np.isfinite(self.readings).all(axis=1)
        self.finite = finite_x


@njit(cache=True)
def _reconstruct(lengths, rates, controls, offset, rest0, substeps, stiffness, damping,
                 max_tension, max_velocity, radius, friction, inertia, kp, kv, min_rest, dt):
    n = lengths.shape[0]
    m = lengths.shape[1]
    rest_out = np.empty((n, m))
    speed_out = np.empty((n, m))
    rest = rest0.copy()
    speed = np.zeros(m)
    target = np.empty(m)
    tension = np.empty(m)
    for i in range(n):
        rest_out[i] = rest
        speed_out[i] = speed
        if i == n - 1:
            break
        for j in range(m):
            target[j] = controls[i, j] + offset[j]
        for s in range(substeps):
            w = (s + 0.5) / substeps
            for j in range(m):
                length = (1 - w) * lengths[i, j] + w * lengths[i + 1, j]
                stretch = length - rest[j]
                if stretch <= 0:
                    tension[j] = 0.0
                else:
                    f_k = stiffness * stretch
                    f_d = damping * rates[i, j]
                    f_d = min(max(f_d, -f_k), f_k)
                    tension[j] = f_k + f_d
            motor_step(rest, speed, target, tension, max_tension, max_velocity, radius, friction,
                       inertia, kp, kv, min_rest, dt)
    return rest_out, speed_out


def reconstruct_actuators(obs: ObservedStates, model: T6Model) -> tuple[np.ndarray, np.ndarray]:
    """Rest lengths and spool speeds (T x 24 each) of θ's motors driven along the observed motion.

    Starts from the build rest lengths of θ (the robot held them while settling), tension from the
    observed cable lengths (linear between samples) and the model's cable law. Samples with
    missing nodes are filled by linear interpolation in time.
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
            previous = controls[i - 1] if i else model.encoder_zero
            controls[i, bad[i]] = previous[bad[i]]
    p, g = model.params, model.options.motor
    substeps = int(round(obs.interval / model.options.dt))
    return _reconstruct(lengths, rates, controls, model.encoder_offset, model.build_rest_length, substeps,
                        p["stiffnessActive"], p["damping"], p["maxTens"], p["targetVelocity"], p["motor_radius"],
                        p["motor_friction"], p["motor_inertia"], g.kp, g.kv, g.min_rest_length, model.options.dt)


def actuator_states(obs: ObservedStates, model: T6Model, source: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """True rest lengths and spool speeds (T x 24) at every sample, from data or reconstructed."""
    if source not in ("auto", "measured", "reconstructed"):
        from physics.errors import ParameterError
        raise ParameterError(f"actuators must be 'auto', 'measured' or 'reconstructed', got {source!r}.")
    if source == "measured" or (source == "auto" and obs.readings is not None):
        if obs.readings is None:
            from physics.errors import TrajectoryFormatError
            raise TrajectoryFormatError("actuators='measured' needs a 'rest_length' variable in the data; "
                                        "use actuators='reconstructed' or 'auto'.")
        rest = obs.readings + model.encoder_offset
        speed = np.zeros_like(rest)
        speed[1:] = np.diff(rest, axis=0) / (obs.interval * model.params["motor_radius"])
        speed[~np.isfinite(speed)] = 0.0
        return rest, speed
    return reconstruct_actuators(obs, model)


def predict(model: T6Model, obs: ObservedStates, start: int, steps: int,
            rest: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """Predicted node positions (steps x 12 x 3) at samples start+1 .. start+steps.

    The simulator is set to the observed state at ``start`` and the recorded controls are
    replayed (held per interval). Raises PhysicsError if the simulation diverges.
    """
    substeps = int(round(obs.interval / model.options.dt))
    model.set_nodes(obs.nodes[start], obs.velocities[start])
    model.rest_length = rest[start].copy()
    model.motor_speed = speed[start].copy()
    out = np.empty((steps, 12, 3))
    for k in range(steps):
        model.step(obs.controls[start + k], n=substeps)
        out[k] = model.node_positions()
    return out
