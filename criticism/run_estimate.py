"""What ``diagnose`` says while it runs: a rough run-time estimate before it starts and one plain line
per stage as it starts and ends, so that a run with its progress bars hidden is not silent for minutes.

The estimate counts the evaluations each stage makes at most, from the settings alone, and multiplies
them by the time of one evaluation measured on the data before the first stage:

- each identification: ``budget`` evaluations, ``1 + passes`` identifications (every pass may add one);
- each least-squares fit (belief.least_squares): per round its ``evaluations`` trial points plus, as a
  rough figure, :data:`JACOBIANS_PER_ROUND` finite-difference Jacobians of D evaluations each;
- the mismatch stage (criticism.mismatch): per round, one fit per component plus the null trial;
- criticism (criticism.search), per pass: each effect's screen of ``grid + refine`` evaluations, then
  ``joint`` joint fits and the re-tuning;
- the wider-box test of the parameters the re-tuning left at a bound (criticism.wider_box), per pass:
  one re-fit, ``WiderBoxConfig.cost`` (counted as if every parameter were pinned on every pass).

The second looks (criticism.revisit) are not counted: they run only when no effect is found. A fit
that converges early makes fewer evaluations, so this is an upper figure of the order of the run, not
a prediction; it is printed as such.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from belief.least_squares import LeastSquaresConfig
from physics.trajectory_objective import TrajectoryObjective

if TYPE_CHECKING:                       # criticism.diagnose imports this module
    from criticism.diagnose import DiagnoseConfig

__all__ = ["JACOBIANS_PER_ROUND", "Announcer", "evaluations", "estimate_line", "run_estimate"]

JACOBIANS_PER_ROUND = 2
"""Finite-difference Jacobians counted per least-squares round (rough: a run makes one per accepted step)."""


@dataclass(frozen=True)
class Announcer:
    """Prints diagnose's stage lines through ``say`` (``print`` on the command line; a no-op when None)."""

    say: Callable[[str], None] | None = None

    def line(self, text: str) -> None:
        """One plain line ``diagnose: TEXT``."""
        if self.say is not None:
            self.say(f"diagnose: {text}")

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Say that stage ``name`` starts, and when it ends how long it took (also when it raises)."""
        self.line(f"{name}: started")
        start = time.perf_counter()
        try:
            yield
        finally:
            self.line(f"{name}: done in {_duration(time.perf_counter() - start)}")


def _duration(seconds: float) -> str:
    return f"{seconds:.1f} s" if seconds < 60 else f"{seconds / 60:.1f} min"


def _fit(local: LeastSquaresConfig, dim: int) -> int:
    """Most evaluations of one least-squares fit in ``dim`` parameters (module docstring)."""
    return local.rounds * (local.evaluations + JACOBIANS_PER_ROUND * dim)


def evaluations(config: DiagnoseConfig, *, dim: int, n_effects: int) -> int:
    """The evaluations the module docstring counts for ``config`` with ``n_effects`` effects to try:
    identifications, the mismatch stage, criticism's screens and fits and the wider-box test, in spaces of
    about ``dim``."""
    identifications = (1 + config.passes) * config.budget
    stage = config.mismatch
    fits = 0 if stage is None else stage.rounds * (len(stage.components) + 1) * _fit(stage.local, dim)
    crit = config.criticism
    per_pass = n_effects * (crit.grid + crit.refine) + (crit.joint + 1) * _fit(crit.local, dim)
    per_pass += 0 if config.wider_box is None else config.wider_box.cost(dim)
    return identifications + fits + config.passes * per_pass


def run_estimate(objective: TrajectoryObjective, config: DiagnoseConfig, *, n_effects: int) -> str:
    """:func:`estimate_line` of ``config``'s evaluations, timing one evaluation of ``objective`` (the fit
    trajectories) at its nominal θ now: the simulations decide the run time, and they depend on the data."""
    theta = np.asarray(objective.space.nominal, float)[None]
    seconds = float(objective.evaluate_batch(theta, parallel=False).seconds[0])
    return estimate_line(evaluations(config, dim=objective.space.dim, n_effects=n_effects), seconds)


def estimate_line(n_evaluations: int, seconds_per_evaluation: float) -> str:
    """The line printed before the run: the evaluations counted, the measured time of one, their product."""
    total = n_evaluations * seconds_per_evaluation
    return (f"estimate: at most about {n_evaluations} evaluations x {seconds_per_evaluation:.2f} s (one, measured "
            f"now) = about {max(1, round(total / 60))} min on this machine (rough: fits that converge early take "
            "less; second looks, when nothing is found, more)")
