"""Controllers: what the robot's motors are told, sample by sample.

A controller has ``reset(model)`` (called once, after settling) and ``__call__(t, model)``
returning the 24 target rest lengths [m] (encoder readings) for the interval starting at time
``t`` [s] since the start of the trajectory. It may look only at what a real robot senses: node
positions (motion capture) and rest-length readings (encoders).

:class:`FlopController` follows the paper's description (Sec. VI-B): assuming the base triangle
(the three lowest nodes) stays on the ground, it commands cable-length changes that move the
centre of mass past the edge of the base triangle facing the goal, so the robot flops onto the
next face. Which cables: the ones with the largest measured effect on the centre of mass along
the goal direction, found by short trial simulations of the controller's own *nominal* model
from the observed state (a plain geometric rule tipped the robot in 1 of 9 trials in an
independent model; this choice tipped it every time).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from physics.errors import ControllerError
from physics.geometry import N_CABLES

if TYPE_CHECKING:                   # annotations; T6Model is imported at run time only when planning (dartpy)
    import xarray as xr

    from physics.tensegrity import T6Model

__all__ = ["Controller", "HoldController", "ReplayController", "FlopController", "FlopPlan", "select_cables",
           "face_headings"]


@runtime_checkable
class Controller(Protocol):
    def reset(self, model: T6Model) -> None: ...

    def __call__(self, t: float, model: T6Model) -> np.ndarray: ...


class HoldController:
    """Keep every rest length where it was at reset."""

    def reset(self, model: T6Model) -> None:
        self._hold = model.rest_length_readings().copy()

    def __call__(self, t: float, model: T6Model) -> np.ndarray:
        return self._hold


class ReplayController:
    """Replay recorded controls (T x 24) sampled at ``times`` (T,), zero-order hold."""

    def __init__(self, times: np.ndarray, controls: np.ndarray) -> None:
        self.times = np.asarray(times, float)
        self.controls = np.asarray(controls, float)
        if self.controls.ndim != 2 or self.controls.shape != (self.times.size, N_CABLES):
            raise ControllerError(f"controls must have shape ({self.times.size}, {N_CABLES}), "
                                  f"got {self.controls.shape}.")
        if not np.all(np.isfinite(self.controls)):
            raise ControllerError("controls contain NaN; fill or drop missing control samples before replaying.")

    @classmethod
    def of(cls, trajectory: xr.Dataset) -> ReplayController:
        """The controls a trajectory recorded (its ``controls`` (time, cable) at its ``time``s), to replay."""
        if "controls" not in trajectory:
            raise ControllerError("the trajectory records no controls to replay (no 'controls' variable).")
        return cls(np.asarray(trajectory["time"].values, float),
                   np.asarray(trajectory["controls"].transpose("time", "cable").values, float))

    def reset(self, model: T6Model) -> None:
        pass

    def __call__(self, t: float, model: T6Model) -> np.ndarray:
        i = int(np.searchsorted(self.times - self.times[0], t + 1e-9, side="right")) - 1
        return self.controls[min(max(i, 0), len(self.times) - 1)]


@dataclass(frozen=True)
class FlopPlan:
    """The cables a flop shortens and lengthens, the goal direction (unit, xy) and the effects
    [m of centre-of-mass motion along it per trial] that chose them."""

    shorten: tuple[int, ...]
    lengthen: tuple[int, ...]
    direction: np.ndarray
    base: tuple[int, int, int]
    effect_shorten: np.ndarray = field(repr=False)
    effect_lengthen: np.ndarray = field(repr=False)


def face_headings(nodes: np.ndarray) -> np.ndarray:
    """Headings [rad in [0, 2π)] of the outward normals of the resting face's three edges, shape ``3``,
    sorted.

    The resting face is the triangle of the three lowest of the 12 nodes (``nodes``: 12 x 3 [m]);
    edge (a, b) has normal n ⟂ (b − a) in the ground plane pointing away from the triangle's centre.
    A flop toward one of these headings tips the robot across that edge, so they are the distinct
    flops of :class:`FlopController` from that face. Raises :class:`ControllerError` for other shapes.
    """
    x = np.asarray(nodes, dtype=float)
    if x.shape != (12, 3) or not np.all(np.isfinite(x)):
        raise ControllerError(f"nodes must be 12 x 3 finite node positions [m], got shape {x.shape}.")
    tri = x[np.argsort(x[:, 2])[:3], :2]
    centre = tri.mean(axis=0)
    out = []
    for k in range(3):
        a, b = tri[k], tri[(k + 1) % 3]
        normal = np.array([b[1] - a[1], a[0] - b[0]])
        if normal @ (0.5 * (a + b) - centre) < 0:
            normal = -normal
        out.append(np.arctan2(normal[1], normal[0]))
    return np.sort(np.mod(out, 2 * np.pi))


def select_cables(plan: FlopPlan, n: int) -> FlopPlan:
    """``plan`` with its cables chosen from its trial effects: shorten the n cables whose shortening
    moves the centre of mass most along the direction, lengthen the n others whose lengthening does.
    The trials do not depend on n, so one set of trials serves every n."""
    shorten = tuple(int(j) for j in np.argsort(-plan.effect_shorten)[:n])
    lengthen = tuple([int(j) for j in np.argsort(-plan.effect_lengthen) if j not in shorten][:n])
    return FlopPlan(shorten, lengthen, plan.direction, plan.base, plan.effect_shorten, plan.effect_lengthen)


class FlopController:
    """Flop toward a goal heading; optionally several flops in a row.

    heading: goal direction in the ground plane [rad from +x]; change: relative rest-length change
    (0.2 = ±20 %); n_cables: how many cables are shortened (and as many lengthened); start, stop:
    when the change is held, relative to each flop's start [s]; period: time between flops [s];
    flops: how many; trial_duration: length of each planning trial [s].
    """

    def __init__(self, heading: float = 0.0, *, change: float = 0.2, n_cables: int = 4,
                 start: float = 0.2, stop: float = 1.2, period: float = 3.0, flops: int = 1,
                 trial_duration: float = 0.3) -> None:
        if not np.isfinite(heading):
            raise ControllerError(f"heading must be a finite angle in radians, got {heading!r}.")
        if not (0.0 < change < 0.5):
            raise ControllerError(f"change must be in (0, 0.5) (relative rest-length change), got {change!r}.")
        if not (1 <= int(n_cables) <= N_CABLES // 2):
            raise ControllerError(f"n_cables must be in 1..{N_CABLES // 2}, got {n_cables!r}.")
        if not (0.0 <= start < stop <= period):
            raise ControllerError(f"need 0 <= start < stop <= period, got start={start}, stop={stop}, period={period}.")
        if int(flops) < 1:
            raise ControllerError(f"flops must be >= 1, got {flops!r}.")
        if not (0.0 < trial_duration <= 2.0):
            raise ControllerError(f"trial_duration must be in (0, 2] s, got {trial_duration!r}.")
        self.heading, self.change, self.n_cables = float(heading), float(change), int(n_cables)
        self.start, self.stop, self.period, self.flops = float(start), float(stop), float(period), int(flops)
        self.trial_duration = float(trial_duration)
        self.plans: list[FlopPlan] = []
        self._planner: T6Model | None = None

    # ------------------------------------------------------------------ planning
    def _planner_model(self, model: T6Model) -> T6Model:
        if self._planner is None:
            from physics.tensegrity import T6Model
            # its own nominal model: the T6 part of the model's nominal θ, no effects
            self._planner = T6Model(model.space.nominal[:15], options=model.options)
        return self._planner

    def plan(self, model: T6Model) -> FlopPlan:
        """Choose the cables from the current observed state of ``model`` (see module docstring)."""
        nodes = model.node_positions()
        readings = model.rest_length_readings()
        lowest = [int(i) for i in np.argsort(nodes[:, 2])[:3]]
        base = (lowest[0], lowest[1], lowest[2])
        goal = np.array([np.cos(self.heading), np.sin(self.heading)])
        tri = nodes[list(base), :2]
        centre = tri.mean(axis=0)
        # the base edge whose outward normal points most toward the goal
        best, direction = -np.inf, goal
        for k in range(3):
            a, b = tri[k], tri[(k + 1) % 3]
            edge = b - a
            normal = np.array([edge[1], -edge[0]]) / np.linalg.norm(edge)
            if normal @ (0.5 * (a + b) - centre) < 0:
                normal = -normal
            if normal @ goal > best:
                best, direction = normal @ goal, normal
        planner = self._planner_model(model)
        steps = int(round(self.trial_duration / planner.options.dt))
        planner.reset()
        planner.set_nodes(nodes)
        planner.rest_length = readings + planner.encoder_offset
        start = planner.get_state()

        def trial(j: int, factor: float) -> float:
            planner.set_state(start)
            target = readings.copy()
            target[j] *= factor
            before = planner.com()[:2]
            planner.step(target, n=steps)
            return float((planner.com()[:2] - before) @ direction)

        short = np.array([trial(j, 1 - self.change) for j in range(N_CABLES)])
        longer = np.array([trial(j, 1 + self.change) for j in range(N_CABLES)])
        return select_cables(FlopPlan((), (), np.r_[direction, 0.0], base, short, longer), self.n_cables)

    # ------------------------------------------------------------------ protocol
    def reset(self, model: T6Model) -> None:
        self.plans = []
        self._base_readings = model.rest_length_readings().copy()
        self._current = self._base_readings

    def __call__(self, t: float, model: T6Model) -> np.ndarray:
        k = int(np.floor(t / self.period + 1e-9))
        if k >= self.flops:
            return self._current
        local = t - k * self.period
        if len(self.plans) <= k:
            self._base_readings = model.rest_length_readings().copy()
            self.plans.append(self.plan(model))
        plan = self.plans[k]
        target = self._base_readings.copy()
        if self.start <= local < self.stop:
            target[list(plan.shorten)] *= 1 - self.change
            target[list(plan.lengthen)] *= 1 + self.change
        self._current = target
        return target
