"""Robust flop planning on a belief: score candidate flops by their outcomes under θ ~ P.

For a goal g (``2`` [m]) and a start centre c₀, a flop with displacement Δ makes progress

    progress = ‖g − c₀‖ − ‖g − c₀ − Δ‖        [m]  (distance to the goal removed; 0 if not "ok")

With ``horizon=2`` (the default) the value of an outcome is instead −flops_to_go: the flops still
needed to be within ``radius`` of the goal, the next flop across each edge of the landing face
simulated under the draws' mean θ (:mod:`planners.lookahead`); a nudge that leaves the robot on its
face does not look free.

Over K draws θ_k ~ P (``belief.sample(K, seed)``) each candidate gets a score by the risk
measure ``risk`` (:data:`RISK_MEASURES`):

- ``"expected"``: mean_k value_k;
- ``"cvar"``: CVaR_α of the values, the mean of the worst α fraction (:func:`cvar`);
- ``"success"``: Pr[success] = mean_k 1{ok, the face changed, progress_k > threshold}, ties broken
  by the expected value.

:func:`plan_flop` picks the best candidate (ties: the first); :func:`plan_to_goal` repeats {plan
under P, execute on the robot (hidden θ*), sense the new state, re-weigh P by the flop's recording
(``learn=True``, the default, :mod:`planners.learning`)} until the robot's centre is within ``radius`` of the goal or
``max_steps`` flops were made. The nominal and MAP plans are the same
planner on a :class:`PointBelief` (all mass on one θ).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from belief.belief import Belief
from belief.sampling import SamplingBelief
from physics.parameters import ParameterSpace
from physics.pool import DaskPool
from physics.tensegrity import T6Model
from planners.actions import FlopAction, candidate_actions
from planners.errors import GoalError, LevelError, PlannerError
from planners.learning import FlopEvidence
from planners.lookahead import flops_to_go, next_flops
from planners.robot import SimulatedRobot
from planners.rollouts import Outcome, RobotStart, RolloutSet, check_belief, pool_for, sample_rollouts

__all__ = ["RISK_MEASURES", "PointBelief", "check_level", "cvar", "progress", "outcome_values", "score", "check_goal",
           "FlopChoice", "plan_flop", "PlanStep", "GoalRun", "plan_to_goal"]

RISK_MEASURES = ("expected", "cvar", "success")


class PointBelief:
    """All mass on one θ (``D``), a :class:`~belief.sampling.SamplingBelief` like :class:`belief.Belief`:
    the nominal plan is ``PointBelief(space.nominal)``, the MAP plan ``PointBelief(belief.map)``."""

    def __init__(self, theta: np.ndarray, space: ParameterSpace | None = None) -> None:
        self.space = space or ParameterSpace.t6()
        self.theta = np.atleast_2d(self.space.as_array(np.asarray(theta, dtype=float), check_bounds=False))
        self.p = np.ones(1)
        self.n_cells = 1

    def sample(self, n: int, *, seed: int | np.random.Generator | None = None) -> np.ndarray:
        """n copies of θ, ``n x D``."""
        return np.repeat(self.theta, int(n), axis=0)

    @property
    def map(self) -> np.ndarray:
        return self.theta[0].copy()


def check_level(level: Any) -> float:
    """α as a float in (0, 1], else :class:`LevelError`."""
    if isinstance(level, bool) or not isinstance(level, (int, float, np.integer, np.floating)) \
            or not math.isfinite(float(level)) or not 0.0 < float(level) <= 1.0:
        raise LevelError(f"level α must be a number in (0, 1] (the worst fraction of outcomes CVaR averages; "
                         f"0.2 = the worst 20 %, 1 = the mean), got {level!r}.")
    return float(level)


def cvar(values: np.ndarray, level: float) -> float:
    """Lower-tail CVaR_α of equally weighted samples x (``K``): with x₍₁₎ <= ... <= x₍K₎ and m = ⌊αK⌋,

        CVaR_α = (Σ_{i<=m} x₍ᵢ₎ + (αK − m) x₍m+1₎) / (αK)

    (the mean of the worst α fraction; α = 1 gives the mean, α -> 0 the minimum).
    """
    alpha = check_level(level)
    x = np.sort(np.asarray(values, dtype=float).ravel())
    if x.size == 0 or not np.all(np.isfinite(x)):
        raise PlannerError(f"cvar needs at least one finite value, got {x.tolist()[:5]}.")
    tail = alpha * x.size
    m = int(math.floor(tail + 1e-12))
    total = x[:m].sum() + (tail - m) * (x[m] if m < x.size else 0.0)
    return float(total / tail)


def progress(displacement: np.ndarray, ok: np.ndarray, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """‖g − c₀‖ − ‖g − c₀ − Δ‖ [m] for displacements ``... x 2``; 0 where not ``ok``."""
    g = np.asarray(goal, dtype=float) - np.asarray(start, dtype=float)
    d = np.where(np.asarray(ok)[..., None], np.nan_to_num(displacement), 0.0)
    return np.linalg.norm(g) - np.linalg.norm(g - d, axis=-1)


def outcome_values(rs: RolloutSet, goal: np.ndarray, *, horizon: int, radius: float,
                   prog: np.ndarray | None = None,
                   nxt: Mapping[tuple[int, ...], np.ndarray] | None = None) -> np.ndarray:
    """The value of every outcome, ``n_a x K``: progress [m] (``horizon`` 1) or −flops to go (2; ``nxt``:
    the simulated next flops of :func:`planners.lookahead.next_flops`)."""
    if horizon not in (1, 2):
        raise PlannerError(f"horizon must be 1 (progress of this flop) or 2 (flops to go, the next one "
                           f"predicted), got {horizon!r}.")
    if horizon == 2:
        return -flops_to_go(rs, goal, radius, nxt)
    return progress(rs.displacement, rs.ok, rs.start.centre, goal) if prog is None else prog


def score(rs: RolloutSet, goal: np.ndarray, *, risk: str = "cvar", level: float = 0.5,
          threshold: float = 0.2, horizon: int = 1, radius: float = 0.5,
          nxt: Mapping[tuple[int, ...], np.ndarray] | None = None,
          values: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(scores ``n_a``, progress ``n_a x K`` [m], success ``n_a x K`` bool) of a rollout set (module
    docstring); the scores are in metres of progress (``horizon`` 1) or in −flops to go (``horizon`` 2).
    ``values``: the outcome values if already computed (:func:`outcome_values`)."""
    if risk not in RISK_MEASURES:
        raise PlannerError(f"risk must be one of the risk measures {RISK_MEASURES}, got {risk!r}.")
    alpha = check_level(level)
    prog = progress(rs.displacement, rs.ok, rs.start.centre, goal)
    value = outcome_values(rs, goal, horizon=horizon, radius=radius, prog=prog, nxt=nxt) if values is None else values
    success = rs.flopped & (prog > threshold)
    if risk == "expected":
        s = value.mean(axis=1)
    elif risk == "cvar":
        s = np.array([cvar(row, alpha) for row in value])
    else:
        s = success.mean(axis=1) + 1e-6 * np.tanh(value.mean(axis=1))   # tie-break by the expected value
    return s, prog, success


def check_goal(goal: Any, centre: np.ndarray, *, radius: float, max_distance: float) -> np.ndarray:
    """The goal as ``2`` [m], after checking it is finite, farther than ``radius`` and within ``max_distance``."""
    try:
        g = np.asarray(goal, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        g = np.full(0, np.nan)
    if g.shape != (2,) or not np.all(np.isfinite(g)):
        raise GoalError(f"goal must be a finite point (x, y) in metres, got {goal!r}; e.g. --goal 2.0 0.5.")
    dist = float(np.linalg.norm(g - centre))
    if dist <= radius:
        raise GoalError(f"the goal {g.tolist()} is {dist:.2f} m from the robot, within the radius {radius:g} m: it is "
                        "already reached; give a goal farther away or a smaller radius.")
    if dist > max_distance:
        raise GoalError(f"the goal {g.tolist()} is {dist:.1f} m away, beyond max_distance = {max_distance:g} m (each "
                        "flop moves about 0.5 m); give a nearer goal or waypoints, or raise max_distance.")
    return g


@dataclass(frozen=True)
class FlopChoice:
    """The chosen flop: ``action`` (index ``index`` of ``rollouts.actions``), ``scores`` ``n_a``,
    ``progress`` ``n_a x K`` [m], ``success`` ``n_a x K``, the ``rollouts``, the settings and
    ``values`` ``n_a x K``, what the scores summarize (:func:`outcome_values`)."""

    action: FlopAction
    index: int
    scores: np.ndarray
    progress: np.ndarray
    success: np.ndarray
    rollouts: RolloutSet = field(repr=False)
    risk: str = "cvar"
    level: float = 0.5
    horizon: int = 2
    values: np.ndarray | None = field(default=None, repr=False)


def _start(start: RobotStart | T6Model | None) -> RobotStart:
    if start is None:
        return RobotStart.settled()
    if isinstance(start, RobotStart):
        return start
    if isinstance(start, T6Model):
        return RobotStart.from_model(start)
    raise PlannerError(f"start must be a RobotStart, a T6Model or None (the nominal robot at rest), got "
                       f"{type(start).__name__}.")


def plan_flop(belief: SamplingBelief, start: RobotStart | T6Model | None, goal: np.ndarray | Sequence[float], *,
              actions: Sequence[FlopAction] | None = None,
              risk: str = "cvar", level: float = 0.5, samples: int = 16, seed: int = 0,
              threshold: float = 0.2, radius: float = 0.5, max_distance: float = 20.0, horizon: int = 2,
              pool: DaskPool | None = None, n_workers: int = 0, progress: bool = False) -> FlopChoice:
    """Best flop from ``start`` (RobotStart, T6Model or None) toward the disc of ``radius`` [m] around
    ``goal`` under K = ``samples`` draws of ``belief`` (seed ``seed``); ``actions`` default:
    :func:`candidate_actions` on the start's face; ``horizon``: 1 or 2 (module docstring)."""
    check_belief(belief)
    check_level(level)
    st = _start(start)
    g = check_goal(goal, st.centre, radius=radius, max_distance=max_distance)
    acts = tuple(actions) if actions is not None else candidate_actions(nodes=st.nodes)
    pool, own = pool_for(pool, n_workers)
    try:
        rs = sample_rollouts(belief, acts, st, samples=samples, seed=seed, pool=pool, progress=progress)
        nxt = next_flops(rs, pool) if horizon == 2 else None
    finally:
        if own:
            pool.close()
    values = outcome_values(rs, g, horizon=horizon, radius=radius, nxt=nxt)
    s, prog, success = score(rs, g, risk=risk, level=level, threshold=threshold, horizon=horizon,
                             radius=radius, values=values)
    k = int(np.argmax(s))
    return FlopChoice(acts[k], k, s, prog, success, rs, risk, float(level), int(horizon), values)


@dataclass(frozen=True)
class PlanStep:
    """One step of a multi-step plan: the ``choice`` made under P and the robot's true ``outcome``;
    ``centre`` before and after [m], the distance to the goal after [m] and the entropy of the
    re-weighed P after the flop [nats] (None when P is not updated)."""

    choice: FlopChoice
    outcome: Outcome
    before: np.ndarray
    after: np.ndarray
    distance: float
    entropy: float | None = None


@dataclass(frozen=True)
class GoalRun:
    """A multi-step run: ``steps``, ``goal`` [m], ``radius`` [m], ``reached`` (within radius), ``start``."""

    steps: tuple[PlanStep, ...]
    goal: np.ndarray
    radius: float
    reached: bool
    start: np.ndarray

    @property
    def path(self) -> np.ndarray:
        """Robot centres [m], ``(steps + 1) x 2``."""
        return np.vstack([self.start] + [s.after for s in self.steps])

    @property
    def final_distance(self) -> float:
        return float(np.linalg.norm(self.path[-1] - self.goal))


def plan_to_goal(belief: SamplingBelief, robot: SimulatedRobot | np.ndarray | None,
                 goal: np.ndarray | Sequence[float], *, radius: float = 0.5, max_steps: int = 8,
                 risk: str = "cvar", level: float = 0.5,
                 samples: int = 16, seed: int = 0, threshold: float = 0.2, horizon: int = 2,
                 learn: bool = True, cells: int = 32, sigma: float = 0.02, actions_kw: dict | None = None,
                 pool: DaskPool | None = None, n_workers: int = 0, progress: bool = True) -> GoalRun:
    """Flop to ``goal`` [m]: repeat {plan_flop under ``belief`` (seed + step), execute on ``robot``
    (a SimulatedRobot, or θ* to build one), sense} until within ``radius`` or ``max_steps`` flops.

    ``learn`` (default on): plan on ``cells`` cells of P re-weighed after every flop by its recording, noise
    ``sigma`` [m] (:class:`~planners.learning.FlopEvidence`; a :class:`PointBelief` is never
    updated). ``actions_kw``: options of :func:`candidate_actions` (changes, n_cables, duration,
    ...), taken on each new resting face.
    """
    check_belief(belief)
    check_level(level)
    robot = robot if isinstance(robot, SimulatedRobot) else SimulatedRobot(robot)
    if isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or max_steps < 1:
        raise PlannerError(f"max_steps must be an integer >= 1, got {max_steps!r}.")
    origin = robot.centre
    g = check_goal(goal, origin, radius=radius, max_distance=20.0)
    evidence = FlopEvidence(belief, cells=cells, seed=seed, sigma=sigma) \
        if learn and isinstance(belief, Belief) else None
    pool, own = pool_for(pool, n_workers)
    steps: list[PlanStep] = []
    try:
        for k in tqdm(range(int(max_steps)), desc="plan_to_goal", disable=not progress, leave=False):
            st = robot.observe()
            acts = candidate_actions(nodes=st.nodes, **(actions_kw or {}))
            choice = plan_flop(evidence.belief() if evidence else belief, st, g, actions=acts, risk=risk,
                               level=level, samples=samples, seed=seed + k, threshold=threshold, radius=radius,
                               horizon=horizon, pool=pool)
            before = robot.centre
            out = robot.execute(choice.action, choice.rollouts.plans[choice.index])
            after, distance = robot.centre, float(np.linalg.norm(robot.centre - g))
            done = distance <= radius or k == int(max_steps) - 1
            entropy = evidence.update(choice.action, st, out, pool=pool) if evidence and not done else None
            steps.append(PlanStep(choice, out, before, after, distance, entropy))
            if distance <= radius:
                break
    finally:
        if own:
            pool.close()
    return GoalRun(tuple(steps), g, float(radius), bool(steps and steps[-1].distance <= radius), origin)
