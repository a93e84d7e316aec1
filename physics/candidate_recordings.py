"""Recordings the robot could make next: flop motions, simulated at a θ and made into an objective.

A :class:`FlopMotion` is one flop of :class:`physics.controllers.FlopController` from rest: toward
``heading`` [rad from +x], ``change`` the relative rest-length change of ``n_cables`` shortened and
as many lengthened cables, held from ``start`` to ``stop`` [s], recorded for ``duration`` [s]. From
a resting face only three flops differ in where they go (:func:`physics.controllers.face_headings`);
the change and the number of cables decide how hard the robot is pushed there, and so which
parameters the motion moves.

:func:`flop_motions` crosses the three edges of the resting face of the settled robot with
changes and cable counts; :func:`candidate_objective` simulates each motion at θ as the data
objective's recordings were made (their sampling rate; velocities recorded only when the data
carry them; no noise, so the objective's Jacobian there is the motion's sensitivity) and returns
one :class:`~physics.trajectory_objective.TrajectoryObjective` with a segment per motion and the
data objective's settings (horizon, actuators, loss, model options, effects, state estimator), on
its workers when it has started some.
"""
from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from physics.controllers import FlopController, face_headings
from physics.errors import ControllerError
from physics.simulation import settled_model, simulate
from physics.trajectory_objective import TrajectoryObjective

__all__ = ["FlopMotion", "flop_motions", "candidate_objective"]


@dataclass(frozen=True)
class FlopMotion:
    """One flop from rest (module docstring); invalid values raise :class:`ControllerError` as
    :class:`FlopController` does. ``as_dict`` has the fields of ``planners.FlopAction``."""

    heading: float
    change: float = 0.2
    n_cables: int = 4
    start: float = 0.2
    stop: float = 1.2
    duration: float = 3.0

    def __post_init__(self) -> None:
        if not all(math.isfinite(float(v)) for v in (self.heading, self.change, self.start, self.stop,
                                                      self.duration)):
            raise ControllerError(f"a flop motion needs finite numbers, got {self!r}.")
        object.__setattr__(self, "heading", float(np.mod(float(self.heading), 2 * np.pi)))
        self.controller()           # FlopController validates change, n_cables and the timing

    def controller(self) -> FlopController:
        """The controller that makes this motion (one flop, period = duration)."""
        return FlopController(self.heading, change=self.change, n_cables=int(self.n_cables), start=self.start,
                              stop=self.stop, period=self.duration, flops=1)

    @property
    def label(self) -> str:
        """Plain words, e.g. "a flop toward 60°: 4 cables 30 % shorter and 4 longer, 0.2-1.2 s of 3 s"."""
        return (f"a flop toward {math.degrees(self.heading):.0f}°: {self.n_cables} cables {self.change:.0%} shorter "
                f"and {self.n_cables} longer, {self.start:g}-{self.stop:g} s of {self.duration:g} s")

    def as_dict(self) -> dict[str, float | int]:
        """JSON-able fields (heading in rad)."""
        return {"heading": self.heading, "change": self.change, "n_cables": int(self.n_cables), "start": self.start,
                "stop": self.stop, "duration": self.duration}


def flop_motions(objective: TrajectoryObjective, theta: np.ndarray, *, changes: Sequence[float],
                 n_cables: Sequence[int], duration: float) -> tuple[FlopMotion, ...]:
    """Edges x changes x cable counts (that nesting order): the three edges of the face the robot at
    θ (D, the objective's space) rests on after settling."""
    model = settled_model(theta, space=objective.space, effects=objective.effects)
    edges = face_headings(model.node_positions())
    return tuple(FlopMotion(float(h), float(c), int(n), duration=float(duration))
                 for h, c, n in itertools.product(edges, changes, n_cables))


def candidate_objective(objective: TrajectoryObjective, theta: np.ndarray,
                        motions: Sequence[FlopMotion]) -> TrajectoryObjective:
    """One objective over the motions simulated at θ (D, the objective's space), a segment each,
    with ``objective``'s settings (module docstring), on ``objective``'s running workers (serially in
    this process when it has none). Raises
    :class:`PhysicsError` when a simulation diverges."""
    if not motions:
        raise ControllerError("candidate_objective needs at least one motion.")
    first = objective.trajectories[0]
    step = float(np.median(np.diff(first["time"].values)))
    recordings = [simulate(theta, controller=m.controller(), duration=m.duration, sample_rate=1.0 / step,
                           space=objective.space, effects=objective.effects, options=objective.options,
                           record_velocities="velocities" in first)
                  for m in motions]
    return TrajectoryObjective(recordings, space=objective.space, horizon=objective.horizon,
                               actuators=objective.actuators, loss=objective.loss, options=objective.options,
                               windows=1, effects=objective.effects, address=objective.scheduler_address, n_workers=0,
                               states=objective.states)
