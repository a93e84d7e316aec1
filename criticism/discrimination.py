"""Which flop would tell two contenders apart: the experiment that separates their predictions most.

When two effects both explain the residual and the evidence cannot tell them apart (criticism.search,
the contest's ``alternatives``), more data of the same kind rarely helps; a flop on which the two
fitted models *predict* different motion does. Each contender c comes with its joint fit, the full
parameter vector θ_c of the model with its effect (Candidate.theta). Under a controller u both
models are simulated open loop from rest, and their separation is

    s(u) = sqrt( mean_{t, node, axis} (x_a(t; θ_a, u) - x_b(t; θ_b, u))² )        [m]

A flop with s(u) well above the sensor noise and above the recorded flops' s is one whose
recording would decide between them. The separation includes what the two fits' own parameters
do differently (a contest can hinge on a parameter neither effect is about, docs/diagnose.md
"Limits"); a flop that exposes that difference pins it, which is what the contest lacked.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr

from criticism.candidate import Candidate
from criticism.errors import CriticismError
from physics.controllers import Controller, FlopController, ReplayController
from physics.effects import Effect, effect_from_config
from physics.errors import PhysicsError
from physics.simulation import simulate

__all__ = ["Separation", "flop_candidates", "recorded_controllers", "separations"]


@dataclass(frozen=True)
class Separation:
    """label of the controller, rms s(u) [m] (module docstring), and whether it replays a recorded flop."""

    label: str
    rms: float
    recorded: bool = False


def flop_candidates(headings: int = 6, patterns: Sequence[tuple[int, float]] = ((4, 0.2), (6, 0.3))
                    ) -> dict[str, FlopController]:
    """One FlopController per heading k·360°/headings and (n_cables, change) pattern, by label."""
    if headings < 1 or not patterns:
        raise CriticismError(f"flop_candidates needs headings >= 1 and at least one pattern, got {headings}, "
                             f"{list(patterns)}.")
    return {f"flop {360 * k / headings:.0f}°, {n} cables ±{change:.0%}":
            FlopController(2 * np.pi * k / headings, n_cables=n, change=change)
            for k in range(headings) for n, change in patterns}


def recorded_controllers(trajectories: Sequence[xr.Dataset]) -> dict[str, ReplayController]:
    """The recorded flops' controls (time, cable) replayed, labelled "recorded t<k>"."""
    return {f"recorded t{k}": ReplayController.of(ds) for k, ds in enumerate(trajectories)}


def _nodes(base: Sequence[Effect], c: Candidate, controller: Controller, duration: float,
           sample_rate: float) -> np.ndarray | None:
    """Contender c's model (the base effects + c's) at θ_c under ``controller``: nodes (T, N, 3), or
    None if the simulation diverges."""
    effects = (*base, effect_from_config(c.config))
    try:
        ds = simulate(np.asarray(c.theta, float), controller=controller, duration=duration, sample_rate=sample_rate,
                      effects=effects, record_velocities=False)
    except PhysicsError:   # diverged: reported as an unbounded separation
        return None
    return np.asarray(ds["nodes"].values, float)


def separations(base: Sequence[Effect], a: Candidate, b: Candidate, controllers: Mapping[str, Controller], *,
                duration: float = 1.5, sample_rate: float = 100.0, recorded: Sequence[str] = ()) -> list[Separation]:
    """s(u) (module docstring) of contenders ``a`` and ``b`` (fits with θ) for each controller, each
    simulated for ``duration`` [s] after the robot settles, largest first. base: the effects of the
    model both were fitted on (the criticized objective's, in its order, so that θ_c lives in
    model_space(base + c's effect); Diagnosis.first_model for the first pass); ``recorded``: the
    labels that replay recorded flops. A controller under which either model diverges separates
    them without bound (rms inf)."""
    if not a.theta or not b.theta:
        raise CriticismError("separations needs two contenders with their fitted parameter vectors "
                             "(Candidate.theta, as criticism's ranking holds them).")
    rows = []
    for label, u in controllers.items():
        xa, xb = (_nodes(base, c, u, duration, sample_rate) for c in (a, b))
        rms = np.inf if xa is None or xb is None else float(np.sqrt(np.mean((xa - xb) ** 2)))
        rows.append(Separation(label, rms, label in recorded))
    return sorted(rows, key=lambda s: -s.rms)
