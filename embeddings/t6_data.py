"""The SUPERball's transition set for the dynamics network, simulated in parallel and cached.

Each of ``n_trajectories`` trajectories draws θ uniformly from the box (the T6 box is ±10 % of
nominal, as in the paper) and a flop heading uniformly in [0, 2π), settles, and flops for
``duration`` seconds at ``sample_rate``. Every ``stride``-th sample i becomes a row::

    context  nodes_i - (com_x, com_y, 0)  (36)   node velocities_i (36)   controls_i (24)      [m, m/s, m]
    target   "com":        com_{i+h} - com_i                      (3)  [m]
             "com_height": z of com_{i+h} - z of com_i            (1)  [m]  (the paper's summary)
             "nodes":      nodes_{i+h} - nodes_i                  (36) [m]

with h = ``horizon`` samples. With ``counterfactual=True`` the target is what θ changes in that
summary instead, as a trajectory error sees it. A second θ' is drawn from the box per trajectory,
independently of the θ that made it; from the recorded state x_i with the recorded controls
(the one-step machinery of :mod:`physics.predictor`, h samples ahead) the motion is predicted
once under θ' and once under the nominal θ₀, and the row is (θ', context_i, the summary of)

    x̂_{i+h}(θ') - x̂_{i+h}(θ₀)                                 (12 x 3)  [m]

The state and the action explain none of θ' (a plain row's state shows its θ, the rod length in
the node distances, so a network may read θ from the context and ignore its θ input), and the
target is zero at θ₀, so all a network learns from θ' is θ's effect.

Simulations run on the :class:`~physics.pool.DaskPool` (the objective's batch machinery), one
item per trajectory, with a progress bar; a trajectory that diverges is dropped and counted
(``attrs["diverged"]``). The set is written to ``cache_dir/t6-transitions-<sha256 of the
settings>.nc`` (netCDF) and read from there next time.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from embeddings.errors import EmbeddingError
from embeddings.transitions import Transitions
from physics.parameters import ParameterSpace

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["T6DataConfig", "t6_transitions", "DEFAULT_CACHE"]

#: where generated training sets are kept (ignored by git); override with $TENSEGRID_CACHE
DEFAULT_CACHE = os.environ.get("TENSEGRID_CACHE", ".cache/tensegrid")
_SUMMARIES = ("com", "com_height", "nodes")


@dataclass(frozen=True)
class T6DataConfig:
    """How the T6 transition set is made (module docstring); the cache key is its JSON."""

    n_trajectories: int = 1200
    duration: float = 1.5
    sample_rate: float = 100.0
    stride: int = 5
    horizon: int = 10
    summary: str = "com"
    seed: int = 0
    counterfactual: bool = False

    def __post_init__(self) -> None:
        for name in ("n_trajectories", "stride", "horizon"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or value < 1:
                raise EmbeddingError(f"T6DataConfig.{name} must be a positive integer, got {value!r}.")
        if self.summary not in _SUMMARIES:
            raise EmbeddingError(f"T6DataConfig.summary must be one of {_SUMMARIES}, got {self.summary!r}.")
        if not (self.duration * self.sample_rate > self.horizon + 1):
            raise EmbeddingError(f"duration {self.duration} s at {self.sample_rate} Hz is too short for a horizon of "
                                 f"{self.horizon} samples; lengthen duration or shorten horizon.")


def _summarize(displacement: np.ndarray, summary: str) -> np.ndarray:
    """Target (m, k) of node displacements (m, 12, 3): the centre of mass's (3), its height's (1) or all (36)."""
    if summary == "com":
        return displacement.mean(axis=1)
    if summary == "com_height":
        return displacement.mean(axis=1)[:, 2:]
    return displacement.reshape(len(displacement), -1)


def _counterfactual(ds: xr.Dataset, theta: np.ndarray, space: ParameterSpace, rows: np.ndarray,
                    horizon: int) -> np.ndarray:
    """x̂_{i+h}(θ) - x̂_{i+h}(θ₀) (m, 12, 3): both predicted from the recorded state at each row."""
    from physics.predictor import ObservedStates, actuator_states, predict
    from physics.tensegrity import T6Model

    obs = ObservedStates(ds)
    out = np.zeros((len(rows), 12, 3))
    for sign, point in ((1.0, theta), (-1.0, space.nominal)):
        model = T6Model(point, space=space)
        rest, speed = actuator_states(obs, model)
        for j, i in enumerate(rows):
            out[j] += sign * predict(model, obs, int(i), horizon, rest, speed)[-1]
    return out


def _features(ds: xr.Dataset, config: T6DataConfig, theta: np.ndarray | None,
              space: ParameterSpace) -> tuple[np.ndarray, np.ndarray]:
    """(context (m, 96), target (m, k)) of one simulated trajectory; ``theta`` is the θ' of a
    counterfactual target (module docstring)."""
    nodes = ds["nodes"].values                       # (T, 12, 3)
    vel = ds["velocities"].values
    controls = ds["controls"].values                 # (T, 24)
    com = nodes.mean(axis=1)                         # (T, 3)
    rows = np.arange(0, len(nodes) - config.horizon, config.stride)
    centred = nodes[rows] - np.concatenate([com[rows, :2], np.zeros((len(rows), 1))], axis=1)[:, None, :]
    context = np.concatenate([centred.reshape(len(rows), -1), vel[rows].reshape(len(rows), -1), controls[rows]], axis=1)
    if config.counterfactual:
        if theta is None:
            raise EmbeddingError("a counterfactual target needs the θ' it is predicted at; pass theta.")
        displacement = _counterfactual(ds, theta, space, rows, config.horizon)
    else:
        displacement = nodes[rows + config.horizon] - nodes[rows]
    return context, _summarize(displacement, config.summary)


def _simulate_one(payload: tuple[ParameterSpace, T6DataConfig],
                  item: tuple[int, np.ndarray, float, np.ndarray]) -> Any:
    """Rows of one trajectory (simulated at θ; targets of θ' when counterfactual), or the divergence
    message (a string) when a simulation fails."""
    from physics.controllers import FlopController
    from physics.errors import PhysicsError
    from physics.simulation import simulate

    space, config = payload
    _, theta, heading, probe = item
    try:
        ds = simulate(theta, controller=FlopController(heading=heading), duration=config.duration,
                      sample_rate=config.sample_rate, space=space, record_velocities=True)
    except PhysicsError as exc:
        return str(exc)
    try:
        return _features(ds, config, probe, space)
    except PhysicsError as exc:
        return str(exc)


def _names(config: T6DataConfig) -> tuple[tuple[str, ...], tuple[str, ...]]:
    axes = ("x", "y", "z")
    context = tuple(f"node{j}_{a}" for j in range(12) for a in axes) + \
        tuple(f"vel{j}_{a}" for j in range(12) for a in axes) + tuple(f"control{c}" for c in range(24))
    target = {"com": tuple(f"dcom_{a}" for a in axes), "com_height": ("dcom_z",),
              "nodes": tuple(f"dnode{j}_{a}" for j in range(12) for a in axes)}[config.summary]
    if config.counterfactual:
        target = tuple(f"{name}_vs_nominal" for name in target)
    return context, target


def cache_path(space: ParameterSpace, config: T6DataConfig, cache_dir: str | os.PathLike[str]) -> Path:
    """``cache_dir/t6-transitions-<key>.nc``: the key hashes the settings and the parameter box."""
    settings = asdict(config)
    if not settings["counterfactual"]:          # absent when off, so the sets cached before it keep their key
        del settings["counterfactual"]
    key = json.dumps({"config": settings, "names": list(space.names), "lower": space.lower.tolist(),
                      "upper": space.upper.tolist(), "format": 1}, sort_keys=True)
    return Path(cache_dir) / f"t6-transitions-{hashlib.sha256(key.encode()).hexdigest()[:16]}.nc"


def t6_transitions(config: T6DataConfig | None = None, *, space: ParameterSpace | None = None,
                   cache_dir: str | os.PathLike[str] | None = DEFAULT_CACHE, workers: int = 2,
                   progress: bool = True) -> Transitions:
    """The T6 transition set of ``config`` (module docstring), from the cache when it is there.

    ``cache_dir=None`` neither reads nor writes a cache. ``workers``: dask worker processes
    (0 = serial). Raises :class:`EmbeddingError` when fewer than two trajectories simulate.
    """
    from tqdm.auto import tqdm

    from physics.pool import DaskPool

    config, space = config or T6DataConfig(), space or ParameterSpace.t6()
    path = None if cache_dir is None else cache_path(space, config, cache_dir)
    if path is not None and path.exists():
        return Transitions.load(path)
    rng = np.random.default_rng(config.seed)
    thetas = space.sample(config.n_trajectories, seed=rng)
    headings = rng.uniform(0.0, 2 * np.pi, config.n_trajectories)
    probes = space.sample(config.n_trajectories, seed=rng) if config.counterfactual else thetas
    items = [(k, thetas[k], float(headings[k]), probes[k]) for k in range(config.n_trajectories)]
    bar = tqdm(total=len(items), desc="simulating T6 transitions", disable=not progress)
    with DaskPool(n_workers=workers) as pool:
        results = pool.map_rows(_simulate_one, (space, config), items, on_result=lambda k, r: bar.update(1))
    bar.close()
    kept = [(k, r) for k, r in enumerate(results) if not isinstance(r, str)]
    if len(kept) < 2:
        raise EmbeddingError(f"only {len(kept)} of {len(items)} T6 trajectories simulated without diverging; "
                             f"first failure: {next((r for r in results if isinstance(r, str)), '')}")
    context_names, target_names = _names(config)
    data = Transitions(
        np.concatenate([np.repeat(probes[k][None], len(r[0]), axis=0) for k, r in kept]),
        np.concatenate([r[0] for _, r in kept]), np.concatenate([r[1] for _, r in kept]),
        np.concatenate([np.full(len(r[0]), k) for k, r in kept]), tuple(space.names), context_names,
        target_names, {"source": "t6_transitions", **asdict(config), "diverged": len(items) - len(kept)})
    if path is not None:
        data.save(path)
    return data
