"""The trajectory error E(θ) of the paper's equation (1), on one or many trajectories.

    E(θ) = Σ_trajectories Σ_i || x_{i+1} - f(x_i, u_i, θ) ||_2          (loss="norm", the paper's)
    E(θ) = Σ_trajectories Σ_i || x_{i+1} - f(x_i, u_i, θ) ||_2^2        (loss="squared")

with x the 36 node coordinates [m] (:mod:`physics.predictor`). The squared loss is a sum of
squared residuals: with Gaussian observation noise of variance σ² per coordinate,
exp(-E/(2σ²)) is the likelihood, which is what belief's ``likelihood`` posterior assumes
(``n_observations`` gives the residual count for estimating σ²). ``horizon`` sets how far each
prediction runs before it is compared:

- ``1``: the paper's one-step error (every sample whose state can be rebuilt);
- ``k``: non-overlapping windows of k samples, each started from the observed state and run
  open loop, every predicted sample compared;
- ``"rollout"``: one free rollout from the first rebuildable state to the end — the "trajectory
  error" of the paper's figures.

Samples with missing observations are skipped. A single evaluation raises :class:`PhysicsError`
if the simulation diverges; :meth:`TrajectoryError.evaluate_batch` records it as a failure and
goes on. Batches run in parallel on dask.distributed: a local cluster (one single-threaded
process per worker, started on first use and reused) or an existing scheduler's address.
"""
from __future__ import annotations

import hashlib
import time as _time
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
import xarray as xr

from physics.errors import ParameterError, PhysicsError, TensegridError, TrajectoryFormatError
from physics.parameters import ParameterSpace
from physics.predictor import ObservedStates, actuator_states, predict
from physics.tensegrity import ModelOptions, T6Model
from physics.trajectory import validate_trajectory

__all__ = ["TrajectoryError", "BatchResult"]


@dataclass(frozen=True)
class BatchResult:
    """Results of a batch: errors (n,) (NaN where failed), status (n,) "ok"/"diverged"/"error",
    seconds (n,) wall time per evaluation, messages (n,) ("" when ok)."""

    errors: np.ndarray
    status: tuple[str, ...]
    seconds: np.ndarray
    messages: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.status)

    def __iter__(self):
        """Rows as (error, status) pairs."""
        return iter(zip(self.errors.tolist(), self.status))


def _warm_up() -> None:
    """Load the compiled kernels in a worker, so the first evaluation is not charged for it."""
    T6Model().step(None, n=2)


def _evaluate_remote(objective: "TrajectoryError", theta: np.ndarray) -> tuple[float, str, float, str]:
    start = _time.perf_counter()
    try:
        value = objective(theta)
        return value, "ok", _time.perf_counter() - start, ""
    except PhysicsError as exc:
        return float("nan"), "diverged", _time.perf_counter() - start, str(exc)


class TrajectoryError:
    """E(θ) on observed trajectories; callable on one θ (D,) or a batch (n x D).

    trajectories: one Dataset or a sequence (docs/data-format.md); horizon: 1, k or "rollout";
    actuators: "reconstructed" (default: θ's motor model is run along the observed motion, so the
    motor parameters act on E), "measured" (rest lengths from the data's encoder readings: the
    motor parameters then barely act on a one-step error) or "auto" (measured if available); options: model options (dt must divide the sampling interval);
    address: a dask scheduler address for batches (default: a local cluster of ``n_workers``
    single-threaded processes; ``n_workers=0`` evaluates batches serially in this process).
    """

    def __init__(self, trajectories: "xr.Dataset | Sequence[xr.Dataset]", *, space: ParameterSpace | None = None,
                 horizon: "int | str" = 1, actuators: str = "reconstructed", loss: str = "norm",
                 options: ModelOptions | None = None,
                 address: str | None = None, n_workers: int = 2) -> None:
        if isinstance(trajectories, xr.Dataset):
            trajectories = [trajectories]
        trajectories = list(trajectories)
        if not trajectories:
            raise TrajectoryFormatError("TrajectoryError needs at least one trajectory, got an empty sequence.")
        self.trajectories = [validate_trajectory(ds) for ds in trajectories]
        self.space = space or ParameterSpace.t6()
        if horizon != "rollout" and not (isinstance(horizon, (int, np.integer)) and horizon >= 1):
            raise ParameterError(f"horizon must be an integer >= 1 or 'rollout', got {horizon!r}.")
        if actuators not in ("auto", "measured", "reconstructed"):
            raise ParameterError(f"actuators must be 'auto', 'measured' or 'reconstructed', got {actuators!r}.")
        if loss not in ("norm", "squared"):
            raise ParameterError(f"loss must be 'norm' (Σ‖r‖, the paper's) or 'squared' (Σ‖r‖²), got {loss!r}.")
        self.horizon, self.actuators, self.loss = horizon, actuators, loss
        self.options = options or ModelOptions()
        if int(n_workers) < 0:
            raise ParameterError(f"n_workers must be >= 0 (0 = serial), got {n_workers!r}.")
        self.address, self.n_workers = address, int(n_workers)
        self._observed = [ObservedStates(ds) for ds in self.trajectories]
        for k, obs in enumerate(self._observed):
            sub = obs.interval / self.options.dt
            if abs(sub - round(sub)) > 1e-6 or round(sub) < 1:
                raise TrajectoryFormatError(
                    f"trajectory {k}: sampling interval {obs.interval:g} s is not a whole number of physics "
                    f"steps dt = {self.options.dt:g} s; resample the data or set ModelOptions(dt=...)."
                )
            if not obs.valid.any():
                raise TrajectoryFormatError(f"trajectory {k}: no sample has a complete state (nodes, velocity "
                                            "estimate and controls); too many NaN.")
        self._client = None
        self._cluster = None
        self._remote = None

    def fingerprint(self) -> dict:
        """What identifies this objective in a journal: a hash of the data and the settings."""
        digest = hashlib.sha256()
        for obs in self._observed:
            for arr in (obs.times, obs.nodes, obs.controls, obs.velocities):
                digest.update(np.ascontiguousarray(arr).tobytes())
        return {"kind": "T6 TrajectoryError", "data_sha256": digest.hexdigest(), "horizon": str(self.horizon),
                "actuators": self.actuators, "loss": self.loss, "options": repr(self.options), "parameters": list(self.space.names)}

    # ------------------------------------------------------------------ windows
    def _windows(self, obs: ObservedStates) -> list[tuple[int, int]]:
        """(start, steps) pairs: starts are rebuildable states, every compared sample observed."""
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

    # ------------------------------------------------------------------ evaluation
    def predictions(self, theta: "np.ndarray | Mapping[str, float] | None" = None) -> list[xr.DataArray]:
        """Predicted node positions f(x_i, u_i, θ) per trajectory, DataArrays (time, node, axis) in
        the layout of the data's ``nodes``; NaN where nothing was predicted (the first samples,
        holes). Raises :class:`PhysicsError` if a simulation diverges."""
        theta = self.space.as_array(theta, check_bounds=False)
        if theta.ndim != 1:
            raise ParameterError(f"predictions take one θ of shape ({self.space.dim},), got {theta.shape}.")
        model = T6Model(theta, space=self.space, options=self.options)
        out = []
        for ds, obs in zip(self.trajectories, self._observed):
            pred = np.full_like(obs.nodes, np.nan)
            rest, speed = actuator_states(obs, model, self.actuators)
            controls_ok = np.isfinite(obs.controls).all(axis=1)
            for start, steps in self._windows(obs):
                if not controls_ok[start:start + steps].all():
                    steps = int(np.argmin(controls_ok[start:start + steps]))
                    if steps == 0:
                        continue
                pred[start + 1:start + 1 + steps] = predict(model, obs, start, steps, rest, speed)
            out.append(xr.DataArray(pred, dims=("time", "node", "axis"), coords=ds["nodes"].coords,
                                    name="predicted_nodes", attrs={"units": "m", "horizon": str(self.horizon)}))
        return out

    def per_sample(self, theta: "np.ndarray | Mapping[str, float] | None" = None) -> list[np.ndarray]:
        """Per-sample errors ||x_i - x̂_i||_2 (T,) for each trajectory, NaN where not compared."""
        return [np.sqrt(((pred.values - obs.nodes) ** 2).sum(axis=(1, 2)))
                for pred, obs in zip(self.predictions(theta), self._observed)]

    def __call__(self, theta: "np.ndarray | Mapping[str, float] | None" = None) -> "float | np.ndarray":
        """E(θ) for one θ (D,) -> float, or a batch (n x D) -> (n,) with NaN for diverged runs."""
        arr = self.space.as_array(theta, check_bounds=False)
        if arr.ndim == 2:
            return self.evaluate_batch(arr).errors
        power = 1 if self.loss == "norm" else 2
        return float(sum(np.nansum(e**power) for e in self.per_sample(arr)))

    @property
    def n_observations(self) -> int:
        """Number of compared coordinates (36 per compared sample), for noise estimates."""
        return int(sum(36 * sum(steps for _, steps in self._windows(obs)) for obs in self._observed))

    # ------------------------------------------------------------------ batches (dask)
    def _get_client(self):
        if self._client is None:
            from distributed import Client, LocalCluster
            if self.address is not None:
                self._client = Client(self.address)
            else:
                try:
                    self._cluster = LocalCluster(n_workers=self.n_workers, threads_per_worker=1, processes=True,
                                                 dashboard_address=None, silence_logs=40)
                except RuntimeError as exc:
                    raise TensegridError(
                        f"Could not start a local dask cluster ({exc}). Worker processes are spawned and import "
                        "your script: put the script's code under `if __name__ == \"__main__\":`, or evaluate "
                        "serially with TrajectoryError(..., n_workers=0)."
                    ) from exc
                self._client = Client(self._cluster)
            self._client.run(_warm_up)
        return self._client

    def evaluate_batch(self, thetas: np.ndarray, *, parallel: bool = True,
                       on_result: "Callable[[int, float, str, float, str], None] | None" = None) -> BatchResult:
        """E at each row of ``thetas`` (n x D); failures are recorded, not raised.

        parallel: run on dask.distributed (local cluster or ``address``); False (or ``n_workers=0``
        without an address) runs in this process. on_result(k, error, status, seconds, message):
        called for each row k as soon as it is done (completion order), e.g. to journal it before
        the rest of the batch returns; the BatchResult keeps the input order.
        """
        thetas = self.space.as_array(thetas, check_bounds=False)
        thetas = np.atleast_2d(thetas)
        rows: list = [None] * len(thetas)
        if parallel and (self.n_workers > 0 or self.address is not None):
            from distributed import as_completed
            client = self._get_client()
            if self._remote is None:    # ship the data to the workers once, not per batch
                self._remote = client.scatter(self, broadcast=True, hash=False)
            futures = client.map(_evaluate_remote, [self._remote] * len(thetas), list(thetas), pure=False)
            index = {f.key: k for k, f in enumerate(futures)}
            for fut in as_completed(futures):
                k = index[fut.key]
                rows[k] = fut.result()
                if on_result is not None:
                    on_result(k, *rows[k])
        else:
            for k, th in enumerate(thetas):
                rows[k] = _evaluate_remote(self, th)
                if on_result is not None:
                    on_result(k, *rows[k])
        return BatchResult(np.array([r[0] for r in rows]), tuple(r[1] for r in rows),
                           np.array([r[2] for r in rows]), tuple(r[3] for r in rows))

    def close(self) -> None:
        """Shut down the local dask cluster, if one was started."""
        if self._client is not None:
            self._client.close()
        if self._cluster is not None:
            self._cluster.close()
        self._client = self._cluster = self._remote = None

    def __enter__(self) -> "TrajectoryError":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_client"] = state["_cluster"] = state["_remote"] = None
        return state

    def __del__(self) -> None:  # pragma: no cover - best effort at interpreter exit
        try:
            self.close()
        except Exception:
            pass
