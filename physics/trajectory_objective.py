"""The trajectory error E(θ) of the paper's equation (1), on one or many trajectories.

    E(θ) = Σ_trajectories Σ_i || x_{i+1} - f(x_i, u_i, θ) ||_2^2        (loss="squared", the default)
    E(θ) = Σ_trajectories Σ_i || x_{i+1} - f(x_i, u_i, θ) ||_2          (loss="norm", the paper's)

with x the 36 node coordinates [m] (:mod:`physics.predictor`). The squared loss is a sum of
squared residuals: with Gaussian observation noise of variance σ² per coordinate,
exp(-E/(2σ²)) is the likelihood, which is what belief's ``likelihood`` posterior assumes
(``n_observations`` gives the residual count for estimating σ²); hence it is the default, here
and in ``tensegrid identify --loss``. ``horizon`` sets how far each
prediction runs before it is compared:

- ``1``: the paper's one-step error (every sample whose state can be rebuilt);
- ``k``: non-overlapping windows of k samples, each started from the observed state and run
  open loop, every predicted sample compared;
- ``"rollout"``: one free rollout from the first rebuildable state to the end — the "trajectory
  error" of the paper's figures. It needs no observation once started, so it runs on through
  dropped frames (samples without nodes or commands), each missing command held at the last one
  sent (physics.predictor.held_commands, as physics.replay does), and is compared only at the
  samples recorded.

Segments: the samples of trajectory k that are compared (those the prediction windows reach,
fixed by the data and ``horizon``, not by θ) are split, in time order, into ``windows``
contiguous groups whose sizes differ by at most one sample (fewer groups when the trajectory has
fewer compared samples than ``windows``). Group j is segment ``f"t{k}/w{j}"``; its part is the
sum above restricted to its samples, so E(θ) = Σ_s parts_s(θ) (:meth:`TrajectoryObjective.evaluate_parts`),
and :meth:`TrajectoryObjective.residuals` returns the residual rows x_i - x̂_i (36 coordinates,
node-major: node 0 x, y, z, node 1 x, ...) of each segment.

Samples with missing observations are skipped. A single evaluation raises :class:`PhysicsError`
if the simulation diverges; :meth:`TrajectoryObjective.evaluate_batch` records it with status
"diverged" and goes on (:mod:`physics.objective` has the contract). Batches run in parallel on
dask.distributed through :class:`physics.pool.DaskPool`: a local cluster (one single-threaded
process per worker, started on first use and reused) or an existing scheduler's address.
"""
from __future__ import annotations

import copy
import hashlib
from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr

from physics.effects.base import Effect, model_space
from physics.errors import ParameterError, TrajectoryFormatError
from physics.objective import BatchResult, OnResult, Row, check_windows, evaluate_row, residual_row
from physics.parameters import ParameterSpace
from physics.pool import DaskPool, map_serial
from physics.predictor import ObservedStates, actuator_states, held_commands, predict, step_options
from physics.state_estimation import DEFAULT_STATES, StateEstimator, position_noise
from physics.tensegrity import ModelOptions, T6Model
from physics.trajectory import regular_clock, validate_trajectory

__all__ = ["TrajectoryObjective", "BatchResult"]


def _warm_up() -> None:
    """Load the compiled kernels in a worker, so the first evaluation is not charged for it."""
    T6Model().step(None, n=2)


class TrajectoryObjective:
    """E(θ) on observed trajectories; callable on one θ (D,), :meth:`evaluate_batch` for a batch (n x D).

    trajectories: one Dataset or a sequence (docs/data-format.md); horizon: 1, k or "rollout";
    actuators: "reconstructed" (default: θ's motor model is run along the observed motion, so the
    motor parameters act on E), "measured" (rest lengths from the data's encoder readings: the
    motor parameters then barely act on a one-step error) or "auto" (measured if available);
    loss: "squared" (default: Σ‖r‖², the sum of squares the likelihood posterior assumes, as the
    command line's --loss) or "norm" (Σ‖r‖, the paper's); options: model options, whose dt must
    divide every trajectory's sampling interval (default None: ModelOptions() with, per trajectory,
    dt = Δ / ceil(Δ / 1 ms), the largest step up to 1 ms that divides its interval Δ;
    physics.predictor.physics_step; the options used
    per trajectory are ``model_options``); trajectories are put on their regular clock first
    (physics.trajectory.regular_clock: jitter snapped, missing timestamps NaN rows);
    windows: segments per trajectory (module docstring); effects: physics.effects parts added to
    the T6 (θ then lives in ``model_space(effects)``: 15 T6 parameters, then the effects');
    address: a dask scheduler address for batches (default: a local cluster of ``n_workers``
    single-threaded processes; ``n_workers=0`` evaluates batches serially in this process);
    states: how the states predictions start from are estimated when the data carry no velocities
    (physics.state_estimation; the default leaves out the samples each prediction is compared with,
    so E's minimum does not move with the measurement noise).
    """

    def __init__(self, trajectories: xr.Dataset | Sequence[xr.Dataset], *, space: ParameterSpace | None = None,
                 horizon: int | str = 1, actuators: str = "reconstructed", loss: str = "squared",
                 options: ModelOptions | None = None, windows: int = 3, effects: Sequence[Effect] = (),
                 address: str | None = None, n_workers: int = 2, states: StateEstimator = DEFAULT_STATES) -> None:
        if isinstance(trajectories, xr.Dataset):
            trajectories = [trajectories]
        trajectories = list(trajectories)
        if not trajectories:
            raise TrajectoryFormatError("TrajectoryObjective needs at least one trajectory, got an empty sequence.")
        self.trajectories = [validate_trajectory(regular_clock(ds)) for ds in trajectories]
        self.effects = tuple(effects)
        self.space = space or model_space(self.effects)
        if self.space.names != model_space(self.effects).names:
            raise ParameterError(f"space must have the parameters {list(model_space(self.effects).names)} of the "
                                 f"T6 and its effects, got {list(self.space.names)}.")
        if horizon != "rollout" and not (isinstance(horizon, (int, np.integer)) and horizon >= 1):
            raise ParameterError(f"horizon must be an integer >= 1 or 'rollout', got {horizon!r}.")
        if actuators not in ("auto", "measured", "reconstructed"):
            raise ParameterError(f"actuators must be 'auto', 'measured' or 'reconstructed', got {actuators!r}.")
        if loss not in ("norm", "squared"):
            raise ParameterError(f"loss must be 'norm' (Σ‖r‖, the paper's) or 'squared' (Σ‖r‖²), got {loss!r}.")
        self.horizon, self.actuators, self.loss = horizon, actuators, loss
        self.windows = check_windows(windows, "segments per trajectory")
        self.options = options
        if not isinstance(states, StateEstimator):
            raise ParameterError(f"states must be a physics.StateEstimator, got {type(states).__name__}.")
        self.states = states
        ahead = None if horizon == "rollout" else int(horizon)
        self._observed = [ObservedStates(ds, states=states, ahead=ahead) for ds in self.trajectories]
        self.model_options = tuple(step_options(obs.interval, options, what=f"trajectory {k}")
                                   for k, obs in enumerate(self._observed))
        self._pool = DaskPool(address, n_workers=n_workers, warm_up=_warm_up)
        for k, obs in enumerate(self._observed):
            if not obs.valid.any():
                raise TrajectoryFormatError(f"trajectory {k}: no sample has a complete state (nodes, velocity "
                                            "estimate and controls); too many NaN.")
        self._groups = [self._segment_groups(k, obs) for k, obs in enumerate(self._observed)]

    @property
    def address(self) -> str | None:
        """The dask scheduler address batches run on, or None for a local cluster / serial."""
        return self._pool.address

    @property
    def scheduler_address(self) -> str | None:
        """The running scheduler's address (``address``, or the local cluster's once started), for another
        objective to share the workers; None when batches run serially or none has run yet."""
        return self._pool.scheduler_address

    @property
    def n_workers(self) -> int:
        """Worker processes of the local cluster (0 = batches run serially in this process)."""
        return self._pool.n_workers

    @property
    def segments(self) -> tuple[str, ...]:
        """Names f"t{k}/w{j}" of the S segments (trajectory k, group j of its compared samples)."""
        return tuple(f"t{k}/w{j}" for k, groups in enumerate(self._groups) for j in range(len(groups)))

    @property
    def noise_var(self) -> float | None:
        """Observation noise variance per coordinate: unknown for data (None); belief estimates it."""
        return None

    @property
    def noise_floor(self) -> float | None:
        """s₀² [m²]: the residual variance per coordinate that the position noise alone leaves, the
        noise measured from each trajectory's recorded nodes and carried through its state estimate
        (physics.state_estimation), averaged over the compared samples; recorded velocities carry
        none (σ² for the compared sample and σ² for the state's position). None for a free rollout
        or the "norm" loss, where E is no sum of squared residuals of one step's noise."""
        if self.horizon == "rollout" or self.loss != "squared":
            return None
        ahead = int(self.horizon)
        floors, weights = [], []
        for ds, obs in zip(self.trajectories, self._observed, strict=True):
            if "velocities" in ds:
                floors.append(2.0 * position_noise(obs.nodes) ** 2)
            else:
                floors.append(self.states.noise_floor(obs.nodes, obs.interval, ahead=ahead))
            weights.append(sum(steps for _, steps in self._windows(obs)))
        return float(np.average(floors, weights=weights))

    def fingerprint(self) -> dict:
        """What identifies this objective in a journal: a hash of the data and the settings, and the segments."""
        digest = hashlib.sha256()
        for obs in self._observed:
            for arr in (obs.times, obs.nodes, obs.controls, obs.state_nodes, obs.velocities):
                digest.update(np.ascontiguousarray(arr).tobytes())
        return {"kind": "T6 TrajectoryObjective", "data_sha256": digest.hexdigest(), "horizon": str(self.horizon),
                "actuators": self.actuators, "loss": self.loss, "options": self._options_record(),
                "parameters": list(self.space.names), "windows": self.windows, "segments": list(self.segments),
                "effects": [e.config() for e in self.effects], "states": self.states.config()}

    # ------------------------------------------------------------------ windows and segments
    def _windows(self, obs: ObservedStates) -> list[tuple[int, int]]:
        """Prediction windows (start, steps): each starts at a rebuildable state and is compared
        at samples start+1 .. start+steps (the horizon's windows, not the segments)."""
        last = len(obs.times) - 1
        if self.horizon == "rollout":
            starts = np.flatnonzero(obs.valid[:last])
            return [(int(starts[0]), last - int(starts[0]))] if starts.size else []
        k = int(self.horizon)
        out, i = [], 0
        while i < last:
            if obs.valid[i]:
                steps = min(k, last - i)
                out.append((i, steps))
                i += steps
            else:
                i += 1
        return out

    def _segment_groups(self, k: int, obs: ObservedStates) -> list[np.ndarray]:
        """The compared sample indices of one trajectory (sorted) split into min(windows, count)
        contiguous groups whose sizes differ by at most one."""
        spans = [np.arange(start + 1, start + 1 + steps) for start, steps in self._windows(obs)]
        compared = np.concatenate(spans) if spans else np.empty(0, dtype=int)
        if compared.size == 0:
            raise TrajectoryFormatError(f"trajectory {k}: no sample can be predicted and compared (a prediction "
                                        "needs a complete state followed by an observed sample); too many NaN.")
        return np.array_split(compared, min(self.windows, compared.size))

    # ------------------------------------------------------------------ evaluation
    def _theta(self, theta: np.ndarray | Mapping[str, float] | None) -> np.ndarray:
        arr = self.space.as_array(theta, check_bounds=False)
        if arr.ndim != 1:
            raise ParameterError(f"one θ of shape ({self.space.dim},) is expected here, got {arr.shape}; "
                                 "use evaluate_batch for a batch (n x D).")
        return arr

    def _options_record(self) -> str | list[str]:
        """The model options for a fingerprint: one repr when every trajectory uses the same, else one each."""
        reprs = [repr(o) for o in self.model_options]
        return reprs[0] if len(set(reprs)) == 1 else reprs

    def _predict(self, theta: np.ndarray) -> list[np.ndarray]:
        """Predicted nodes (T x 12 x 3) per trajectory, NaN where not predicted. One pass of the simulator
        per trajectory, on one model per distinct options (physics step). A window ends before a sample
        without commands; the free rollout runs on through dropped frames with the last command held
        (module docstring)."""
        models: dict[ModelOptions, T6Model] = {}
        out = []
        for obs, options in zip(self._observed, self.model_options, strict=True):
            if options not in models:
                models[options] = T6Model(theta, space=self.space, options=options, effects=self.effects)
            model = models[options]
            pred = np.full_like(obs.nodes, np.nan)
            rest, speed = actuator_states(obs, model, self.actuators)
            controls = held_commands(obs.controls) if self.horizon == "rollout" else obs.controls
            controls_ok = np.isfinite(controls).all(axis=1)
            for start, steps in self._windows(obs):
                if not controls_ok[start:start + steps].all():
                    steps = int(np.argmin(controls_ok[start:start + steps]))
                    if steps == 0:
                        continue
                pred[start + 1:start + 1 + steps] = predict(model, obs, start, steps, rest, speed, controls=controls)
            out.append(pred)
        return out

    def predictions(self, theta: np.ndarray | Mapping[str, float] | None = None) -> list[xr.DataArray]:
        """Predicted node positions f(x_i, u_i, θ) per trajectory, DataArrays (time, node, axis) in
        the layout of the data's ``nodes``; NaN where nothing was predicted (the first samples,
        holes). Raises :class:`PhysicsError` if a simulation diverges."""
        preds = self._predict(self._theta(theta))
        return [xr.DataArray(pred, dims=("time", "node", "axis"), coords=ds["nodes"].coords,
                             name="predicted_nodes", attrs={"units": "m", "horizon": str(self.horizon)})
                for pred, ds in zip(preds, self.trajectories, strict=True)]

    def _sample_errors(self, preds: list[np.ndarray]) -> list[np.ndarray]:
        return [np.sqrt(((pred - obs.nodes) ** 2).sum(axis=(1, 2)))
                for pred, obs in zip(preds, self._observed, strict=True)]

    def per_sample(self, theta: np.ndarray | Mapping[str, float] | None = None) -> list[np.ndarray]:
        """Per-sample errors ||x_i - x̂_i||_2 (T,) for each trajectory, NaN where not compared."""
        return self._sample_errors(self._predict(self._theta(theta)))

    def evaluate_parts(self, theta: np.ndarray | Mapping[str, float] | None = None) -> np.ndarray:
        """Per-segment errors (S,) in the order of :attr:`segments`: part (k, j) = Σ_{i in group j of
        trajectory k} ||x_i - x̂_i||_2 (loss "norm") or its square (loss "squared"), NaN samples
        skipped; the parts sum to E(θ). Raises :class:`PhysicsError` if a simulation diverges."""
        power = 1 if self.loss == "norm" else 2
        parts = [np.nansum(errors[group] ** power)
                 for errors, groups in zip(self.per_sample(theta), self._groups, strict=True) for group in groups]
        return np.asarray(parts, dtype=float)

    def residuals(self, theta: np.ndarray | Mapping[str, float] | None = None) -> list[np.ndarray]:
        """Residuals x_i - x̂_i per segment: S arrays (T_s, 36), node-major coordinates [m], one row per
        sample from the segment's first to its last compared sample (time order), NaN rows where
        nothing was compared. Σ_s nansum(r_s²) equals E(θ) for loss "squared"; Σ_s Σ_rows ||r|| for "norm"."""
        out: list[np.ndarray] = []
        for pred, obs, groups in zip(self._predict(self._theta(theta)), self._observed, self._groups, strict=True):
            diff = (obs.nodes - pred).reshape(len(pred), 36)
            diff[~np.isfinite(diff).all(axis=1)] = np.nan
            out.extend(diff[group[0]:group[-1] + 1] for group in groups)
        return out

    def __call__(self, theta: np.ndarray | Mapping[str, float] | None = None) -> float:
        """E(θ) = Σ_s parts_s for one θ (D,) (the nominal θ if None). A batch (n x D) goes through
        :meth:`evaluate_batch`, which records failures instead of raising."""
        return float(self.evaluate_parts(theta).sum())

    @property
    def n_observations(self) -> int:
        """Number of compared coordinates (36 per compared sample), for noise estimates."""
        return int(sum(36 * sum(steps for _, steps in self._windows(obs)) for obs in self._observed))

    # ------------------------------------------------------------------ batches
    def evaluate_batch(self, thetas: np.ndarray, *, parallel: bool = True,
                       on_result: OnResult | None = None) -> BatchResult:
        """E and its parts at each row of ``thetas`` (n x D); failures are recorded, not raised.

        Statuses: "ok", "diverged" (:class:`PhysicsError`), "failed" (another tensegrid error or a
        non-finite E). parallel: run on dask.distributed (local cluster or ``address``); False (or
        ``n_workers=0`` without an address) runs in this process. on_result(k, error, status,
        seconds, message, parts (S,)): called for each row k as soon as it is done (completion
        order), e.g. to journal it before the rest of the batch returns; the result keeps the input order.
        """
        thetas = np.atleast_2d(self.space.as_array(thetas, check_bounds=False))
        if thetas.ndim != 2:
            raise ParameterError(f"thetas must have shape (n, {self.space.dim}), got {thetas.shape}.")

        callback = None
        if on_result is not None:
            report = on_result

            def callback(k: int, row: Row) -> None:
                report(k, *row)
        if parallel:
            rows = self._pool.map_rows(evaluate_row, self, list(thetas), callback)
        else:
            rows = map_serial(evaluate_row, self, list(thetas), callback)
        return BatchResult.from_rows(rows, len(self.segments))

    def residuals_batch(self, thetas: np.ndarray, *, parallel: bool = True) -> list[list[np.ndarray] | None]:
        """:meth:`residuals` at each row of ``thetas`` (n x D), on the workers like :meth:`evaluate_batch`;
        None for a row whose simulation diverged or failed."""
        thetas = np.atleast_2d(self.space.as_array(thetas, check_bounds=False))
        if thetas.ndim != 2:
            raise ParameterError(f"thetas must have shape (n, {self.space.dim}), got {thetas.shape}.")
        if parallel:
            return self._pool.map_rows(residual_row, self, list(thetas))
        return map_serial(residual_row, self, list(thetas))

    def with_effects(self, effects: Sequence[Effect]) -> TrajectoryObjective:
        """The same data and settings with the model's effects replaced by ``effects`` (θ then lives
        in ``model_space(effects)``, whose T6 parameters keep this objective's box: a prior box given
        at construction holds as effects join); shares this objective's worker pool."""
        n_base = self.space.dim - sum(len(e.parameters()) for e in self.effects)
        other = copy.copy(self)
        other.effects = tuple(effects)
        other.space = model_space(other.effects, base=ParameterSpace(self.space.parameters[:n_base]))
        return other

    def select(self, trajectories: Sequence[int]) -> TrajectoryObjective:
        """The same settings on a subset of the trajectories (indices, in the given order); shares
        this objective's worker pool. Segments are renumbered t0.. in the new order."""
        index = [int(k) for k in trajectories]
        if not index or any(k not in range(len(self.trajectories)) for k in index):
            raise ParameterError(f"select needs trajectory indices in 0..{len(self.trajectories) - 1}, got {index}.")
        other = copy.copy(self)
        other.trajectories = [self.trajectories[k] for k in index]
        other._observed = [self._observed[k] for k in index]
        other.model_options = tuple(self.model_options[k] for k in index)
        other._groups = [self._groups[k] for k in index]
        return other

    def close(self) -> None:
        """Shut down the local dask cluster, if one was started."""
        self._pool.close()

    def __enter__(self) -> TrajectoryObjective:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
