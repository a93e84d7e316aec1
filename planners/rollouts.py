"""Rollouts: one flop simulated from a given start under many θ, in parallel.

The start is what the robot senses (:class:`RobotStart`): node positions (motion capture, 12 x 3
[m]) and encoder rest lengths (24 [m]). A simulation at θ places the rods at those nodes (at rest,
lifted so the lowest cap touches the ground under θ's cap radius), sets the true rest lengths to
readings + θ's encoder offset, runs the flop, and holds until the robot is at rest (as
:class:`planners.robot.SimulatedRobot` does after each flop). The cables of a flop are chosen once per start
by the controller's own nominal model (:meth:`physics.controllers.FlopController.plan`, as the
robot would), and every θ executes that same open-loop command (:func:`plan_cables`).

An :class:`Outcome` holds the displacement of the centre of the nodes in the ground plane
(Δc = c_end − c_start, ``2`` [m]; the rods are symmetric, so it is the centre-of-mass
displacement), the resting face reached (the three lowest nodes, sorted), the final sensed state,
the recorded nodes (``T x 12 x 3`` at ``record_rate``) and a status from
:data:`physics.objective.STATUSES`: "ok", or "diverged" when physics raised
:class:`~physics.errors.PhysicsError` (recorded, never hidden; displacement NaN).

Rows run on :meth:`physics.pool.DaskPool.map_rows` (serially with ``n_workers=0``); identical θ
rows (cells drawn twice) are simulated once.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from belief.sampling import SamplingBelief
from physics.controllers import FlopController, FlopPlan, select_cables
from physics.errors import PhysicsError
from physics.geometry import rod_poses_from_nodes
from physics.parameters import ParameterSpace
from physics.pool import DaskPool
from physics.simulation import settled_model
from physics.tensegrity import RobotState, T6Model
from planners.actions import FlopAction
from planners.errors import ActionError, EmptyBeliefError, PlannerError, RobotMismatchError

__all__ = ["RobotStart", "Outcome", "RolloutSet", "check_belief", "place", "plan_cables", "plan_all",
           "run_flop", "rollouts", "sample_rollouts", "pool_for", "warm_up"]

_SAMPLE_RATE = 100.0     # controller rate [Hz], as physics.simulation
_LIFT = 5e-4             # gap left under the lowest cap when placing rods [m]


@dataclass(frozen=True)
class RobotStart:
    """What the robot senses at rest: ``nodes`` 12 x 3 [m], ``readings`` 24 encoder rest lengths [m]."""

    nodes: np.ndarray
    readings: np.ndarray

    def __post_init__(self) -> None:
        nodes, readings = np.array(self.nodes, dtype=float), np.array(self.readings, dtype=float)
        if nodes.shape != (12, 3) or readings.shape != (24,) or not (np.all(np.isfinite(nodes))
                                                                      and np.all(np.isfinite(readings))):
            raise PlannerError(f"a start needs finite nodes (12 x 3) [m] and readings (24,) [m], got shapes "
                               f"{nodes.shape} and {readings.shape}; use RobotStart.settled() or .from_model(model).")
        nodes.setflags(write=False)
        readings.setflags(write=False)
        object.__setattr__(self, "nodes", nodes)
        object.__setattr__(self, "readings", readings)

    @classmethod
    def from_model(cls, model: T6Model) -> RobotStart:
        """The sensed state of a :class:`T6Model` (observed nodes, encoder readings)."""
        return cls(model.observe(model.node_positions()), model.rest_length_readings())

    @classmethod
    def settled(cls, theta: np.ndarray | None = None, *, settle: float = 2.0) -> RobotStart:
        """The robot at θ (nominal by default) after ``settle`` seconds of rest from its build state."""
        return cls.from_model(settled_model(theta, settle=settle))

    @property
    def centre(self) -> np.ndarray:
        """Centre of the nodes in the ground plane, ``2`` [m]."""
        return self.nodes[:, :2].mean(axis=0)

    @property
    def face(self) -> tuple[int, int, int]:
        """The resting face: the three lowest nodes, sorted."""
        return tuple(sorted(int(i) for i in np.argsort(self.nodes[:, 2])[:3]))  # type: ignore[return-value]


@dataclass(frozen=True)
class Outcome:
    """One simulated flop: ``displacement`` 2 [m] (NaN unless ok), ``face`` (three node indices, () unless
    ok), ``final`` sensed state (None unless ok), ``nodes`` T x 12 x 3 [m] recorded at the set's rate
    (NaN after a divergence), ``status`` "ok" or "diverged", ``message`` why not ok."""

    displacement: np.ndarray
    face: tuple[int, ...]
    final: RobotStart | None
    nodes: np.ndarray = field(repr=False)
    status: str = "ok"
    message: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def path(self) -> np.ndarray:
        """Centre of the nodes in the ground plane along the flop, ``T x 2`` [m]."""
        return self.nodes[:, :, :2].mean(axis=1)


class _PlannedFlop(FlopController):
    """A FlopController whose cables were chosen beforehand (the same command for every θ)."""

    def __init__(self, action: FlopAction, fixed: FlopPlan) -> None:
        c = action.controller()
        super().__init__(c.heading, change=c.change, n_cables=c.n_cables, start=c.start, stop=c.stop,
                         period=c.period, flops=1)
        self._fixed = fixed

    def plan(self, model: T6Model) -> FlopPlan:
        return self._fixed


def place(theta: np.ndarray | None, start: RobotStart) -> T6Model:
    """A T6Model at θ (``D``; nominal if None) at rest at ``start``'s nodes, lowest cap on the ground."""
    model = T6Model(theta)
    rest = start.readings + model.encoder_offset
    nodes = model.unobserve(np.array(start.nodes))
    for _ in range(2):   # second pass: lift by the difference θ's geometry makes
        q, dq = rod_poses_from_nodes(nodes)
        model.set_state(RobotState(q, dq, rest, np.zeros(24), rest.copy(), 0.0))
        nodes = nodes + [0.0, 0.0, model.setup.cap_radius + _LIFT - model.node_positions()[:, 2].min()]
    return model


def plan_cables(action: FlopAction, start: RobotStart) -> FlopPlan:
    """The cables ``action`` shortens and lengthens from ``start``, chosen by the controller's nominal model."""
    return action.controller().plan(place(None, start))


def plan_all(actions: Sequence[FlopAction], start: RobotStart, pool: DaskPool) -> tuple[FlopPlan, ...]:
    """:func:`plan_cables` of every action, with one trial set per distinct (heading, change) on ``pool``."""
    keys = [(a.heading, a.change) for a in actions]
    distinct = list(dict.fromkeys(keys))
    firsts = [actions[keys.index(k)] for k in distinct]
    base = dict(zip(distinct, pool.map_rows(_plan_row, start, firsts), strict=True))
    return tuple(select_cables(base[k], a.n_cables) for k, a in zip(keys, actions, strict=True))


def _rest(model: T6Model, speed: float, limit: float) -> None:
    """Hold the current targets until every node is slower than ``speed`` [m/s] or ``limit`` [s] passed."""
    chunk = int(round(0.05 / model.options.dt))
    for _ in range(int(round(limit / 0.05))):
        if np.linalg.norm(model.node_velocities(), axis=1).max() < speed:
            return
        model.step(None, n=chunk)


def run_flop(model: T6Model, action: FlopAction, plan: FlopPlan, *, record_rate: float = 10.0,
             rest_speed: float = 0.05, rest_limit: float = 2.0) -> Outcome:
    """Run ``action`` with cables ``plan`` on ``model`` from its current state, then hold until at rest
    (nodes slower than ``rest_speed`` [m/s], at most ``rest_limit`` [s]); the model keeps the end state.

    Records the observed nodes at t = 0, 1/record_rate, ..., duration (T = duration·rate + 1 rows);
    displacement, face and final state are taken at rest.
    """
    every = int(round(_SAMPLE_RATE / record_rate))
    substeps = int(round(1.0 / (_SAMPLE_RATE * model.options.dt)))
    n = int(round(action.duration * _SAMPLE_RATE))
    rec = np.full((n // every + 1, 12, 3), np.nan)
    rec[0] = model.observe(model.node_positions())
    ctrl = _PlannedFlop(action, plan)
    ctrl.reset(model)
    try:
        for i in range(n):
            model.step(ctrl(i / _SAMPLE_RATE, model), n=substeps)
            if (i + 1) % every == 0:
                rec[(i + 1) // every] = model.observe(model.node_positions())
        _rest(model, rest_speed, rest_limit)
    except PhysicsError as exc:
        return Outcome(np.full(2, np.nan), (), None, rec, "diverged", str(exc))
    final = RobotStart.from_model(model)
    return Outcome(final.centre - rec[0, :, :2].mean(axis=0), final.face, final, rec)


@dataclass(frozen=True)
class _Task:
    start: RobotStart
    actions: tuple[FlopAction, ...]
    plans: tuple[FlopPlan, ...]
    record_rate: float


def _plan_row(start: RobotStart, action: FlopAction) -> FlopPlan:
    return plan_cables(action, start)


def _rollout_row(task: _Task, item: tuple[int, np.ndarray]) -> Outcome:
    a, theta = item
    try:
        model = place(theta, task.start)
    except PhysicsError as exc:
        return Outcome(np.full(2, np.nan), (), None, np.full((1, 12, 3), np.nan), "diverged", str(exc))
    return run_flop(model, task.actions[a], task.plans[a], record_rate=task.record_rate)


def warm_up() -> None:
    """Load the compiled kernels in a worker, so the first rollout is not charged for it."""
    T6Model().step(None, n=2)


@dataclass(frozen=True)
class RolloutSet:
    """Outcomes of n_a actions under K parameter vectors: ``outcomes[a][k]``; ``thetas`` K x D; ``plans``
    the cables of each action (same for every θ); ``start`` the common start."""

    actions: tuple[FlopAction, ...]
    thetas: np.ndarray
    outcomes: tuple[tuple[Outcome, ...], ...]
    plans: tuple[FlopPlan, ...]
    start: RobotStart

    @property
    def displacement(self) -> np.ndarray:
        """``n_a x K x 2`` [m], NaN where not ok."""
        return np.array([[o.displacement for o in row] for row in self.outcomes]).reshape(len(self.actions), -1, 2)

    @property
    def ok(self) -> np.ndarray:
        """``n_a x K`` bool: status "ok"."""
        return np.array([[o.ok for o in row] for row in self.outcomes], dtype=bool).reshape(len(self.actions), -1)

    @property
    def flopped(self) -> np.ndarray:
        """``n_a x K`` bool: ok and the resting face changed."""
        f0 = self.start.face
        return np.array([[o.ok and o.face != f0 for o in row] for row in self.outcomes],
                        dtype=bool).reshape(len(self.actions), -1)


def pool_for(pool: DaskPool | None, n_workers: int) -> tuple[DaskPool, bool]:
    """(``pool``, False) if given, else (a new DaskPool of ``n_workers`` with :func:`warm_up`, True: close it)."""
    if pool is not None:
        return pool, False
    return DaskPool(n_workers=n_workers, warm_up=warm_up), True


def rollouts(actions: Sequence[FlopAction], start: RobotStart, thetas: np.ndarray, *, pool: DaskPool | None = None,
             n_workers: int = 0, record_rate: float = 10.0, progress: bool = False) -> RolloutSet:
    """Simulate every action (n_a) from ``start`` under every row of ``thetas`` (K x 15).

    ``pool``: a DaskPool to reuse (else one of ``n_workers`` is made and closed; 0 = serial).
    Duplicate θ rows are simulated once. Diverged simulations are outcomes with status "diverged".
    """
    acts = tuple(actions)
    if not acts or not all(isinstance(a, FlopAction) for a in acts):
        raise ActionError(f"actions must be a non-empty sequence of FlopAction, got {list(acts)[:3]!r}.")
    th = np.atleast_2d(np.asarray(thetas, dtype=float))
    if th.shape[0] < 1 or th.shape[1] != 15 or not np.all(np.isfinite(th)):
        raise EmptyBeliefError(f"thetas must be K x 15 finite parameter vectors with K >= 1, got shape {th.shape}; "
                               "draw them with belief.sample(K, seed=...).")
    if not (np.isfinite(record_rate) and 0 < record_rate <= _SAMPLE_RATE and
            abs(_SAMPLE_RATE / record_rate - round(_SAMPLE_RATE / record_rate)) < 1e-9):
        raise PlannerError(f"record_rate must divide {_SAMPLE_RATE:g} Hz (e.g. 10 or 20), got {record_rate!r}.")
    unique, inverse = np.unique(th, axis=0, return_inverse=True)
    pool, own = pool_for(pool, n_workers)
    try:
        plans = plan_all(acts, start, pool)
        task = _Task(start, acts, plans, float(record_rate))
        items = [(a, unique[k]) for a in range(len(acts)) for k in range(len(unique))]
        bar = tqdm(total=len(items), desc="rollouts", disable=not progress, leave=False)
        rows = pool.map_rows(_rollout_row, task, items, lambda k, r: bar.update())
        bar.close()
    finally:
        if own:
            pool.close()
    grid = [rows[a * len(unique):(a + 1) * len(unique)] for a in range(len(acts))]
    outcomes = tuple(tuple(grid[a][int(k)] for k in inverse.ravel()) for a in range(len(acts)))
    return RolloutSet(acts, th, outcomes, plans, start)


def check_belief(belief: SamplingBelief) -> None:
    """Raise if ``belief`` is not a :class:`~belief.sampling.SamplingBelief`, is empty (no cells, no
    mass) or is from another robot (not the T6's 15 parameters)."""
    if not isinstance(belief, SamplingBelief) or not isinstance(belief.space, ParameterSpace):
        raise PlannerError(f"belief must be a belief.Belief or another belief.sampling.SamplingBelief (.space, .theta, "
                           f".p, .sample), got {type(belief).__name__}; load one with Belief.load(path).")
    space = belief.space
    p = np.asarray(belief.p, dtype=float)
    t6 = ParameterSpace.t6()
    if tuple(space.names) != tuple(t6.names):
        raise RobotMismatchError(f"the belief is over {space.dim} parameters {list(space.names)[:5]}..., "
                                 f"but the planner simulates the T6 ({t6.dim} parameters {list(t6.names)[:3]}...); "
                                 "identify on trajectories of this robot (tensegrid identify) and plan with that "
                                 "belief.")
    if p.size == 0 or not np.all(np.isfinite(p)) or not p.sum() > 0:
        raise EmptyBeliefError(f"the belief has {p.size} cells and total mass {float(p.sum()) if p.size else 0.0!r}; "
                               "it holds nothing to plan with: run an identification (tensegrid identify) first.")


def sample_rollouts(belief: SamplingBelief, actions: Sequence[FlopAction], start: RobotStart, *, samples: int,
                    seed: int, **kw: Any) -> RolloutSet:
    """:func:`rollouts` under θ = ``belief.sample(samples, seed=seed)`` (K = samples x 15)."""
    check_belief(belief)
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise EmptyBeliefError(f"samples must be an integer >= 1 (θ draws per action), got {samples!r}.")
    return rollouts(actions, start, belief.sample(int(samples), seed=seed), **kw)
