"""The "real" robot of an experiment: a simulation at a hidden θ* that keeps its full state.

A planner sees only what :meth:`SimulatedRobot.observe` returns (the sensed
:class:`~planners.rollouts.RobotStart`, with optional motion-capture noise) and the node recording
of each executed flop. The robot itself continues from its true simulator state, so the model
error of placing rods at sensed nodes (zero velocities, the planner's θ) is on the planner's side
only. After each flop the robot holds its rest lengths until every node is slower than
``rest_speed`` [m/s] or ``rest_limit`` [s] have passed (it is at rest before the next plan).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from physics.controllers import FlopPlan
from physics.parameters import ParameterSpace
from physics.simulation import settled_model
from planners.actions import FlopAction
from planners.errors import PlannerError
from planners.rollouts import Outcome, RobotStart, plan_cables, run_flop

__all__ = ["SimulatedRobot"]


class SimulatedRobot:
    """The T6 at θ* (``theta``: 15 values, nominal if None), settled ``settle`` s on its build face.

    ``noise``: std [m] of Gaussian noise on every sensed node position (``seed``: its generator);
    ``rest_speed`` [m/s], ``rest_limit`` [s]: the wait after each flop (module docstring).
    """

    def __init__(self, theta: np.ndarray | None = None, *, settle: float = 2.0, noise: float = 0.0, seed: int = 0,
                 rest_speed: float = 0.05, rest_limit: float = 2.0) -> None:
        space = ParameterSpace.t6()
        self.theta = space.nominal.copy() if theta is None else space.as_array(theta, check_bounds=False)
        if self.theta.shape != (space.dim,):
            raise PlannerError(f"theta must be one θ of the T6 ({space.dim} values), got shape {self.theta.shape}.")
        if not (np.isfinite(noise) and noise >= 0):
            raise PlannerError(f"noise must be a standard deviation >= 0 m, got {noise!r}.")
        self.model = settled_model(self.theta, settle=settle)
        self.noise, self.rest_speed, self.rest_limit = float(noise), float(rest_speed), float(rest_limit)
        self._rng = np.random.default_rng(seed)
        self.outcomes: list[Outcome] = []

    def _sense(self, nodes: np.ndarray) -> np.ndarray:
        if self.noise == 0.0:
            return nodes
        return nodes + self._rng.normal(0.0, self.noise, nodes.shape)

    def observe(self) -> RobotStart:
        """The sensed state now: node positions (with noise) and encoder readings."""
        true = RobotStart.from_model(self.model)
        return RobotStart(self._sense(np.array(true.nodes)), true.readings)

    @property
    def centre(self) -> np.ndarray:
        """True centre of the nodes in the ground plane, ``2`` [m]."""
        return RobotStart.from_model(self.model).centre

    def execute(self, action: FlopAction, plan: FlopPlan | None = None, *, record_rate: float = 10.0) -> Outcome:
        """Run ``action`` (cables ``plan``, else chosen now from the sensed state), then wait to rest.

        Returns the :class:`Outcome` with the true displacement and face, and the sensed (noisy) node
        recording and final state; a diverged flop is returned with status "diverged" and the robot
        is put back in its state before the flop (no raise).
        """
        plan = plan if plan is not None else plan_cables(action, self.observe())
        before = self.model.get_state()
        out = run_flop(self.model, action, plan, record_rate=record_rate, rest_speed=self.rest_speed,
                       rest_limit=self.rest_limit)
        if not out.ok:
            self.model.set_state(before)
        final = self.observe() if out.ok else None
        out = Outcome(out.displacement, out.face, final, self._sense(out.nodes), out.status, out.message)
        self.outcomes.append(out)
        return out

    def __repr__(self) -> str:
        return f"SimulatedRobot(centre={np.round(self.centre, 3).tolist()}, flops={len(self.outcomes)})"

    def config(self) -> dict[str, Any]:
        """JSON-able description (θ*, noise)."""
        return {"theta": self.theta.tolist(), "noise": self.noise}
