"""Record a flop of the testbed robot as a trajectory in the project's data format.

Format (docs/data-format.md, written here with xarray only): ``nodes`` (time, node, axis) in the
world frame [m], z up; ``controls`` and ``rest_length`` (time, cable) as encoder readings [m];
coordinates ``time`` [s], ``node``, ``axis``, ``cable`` with ``end_a``/``end_b``. Missing samples
are NaN rows. The θ and effects that made the data go in attributes ``testbed_theta`` and
``testbed_effects`` (JSON), which an identifier does not read.
"""
from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import xarray as xr

from testbed.cable_robot import CableRobot
from testbed.controller import Flop, FlopPlanner
from testbed.params import CABLE_ENDS, cable_names

__all__ = ["Observation", "record_flop", "to_dataset"]


@dataclass(frozen=True)
class Observation:
    """How the robot is observed: sampling rate [Hz], Gaussian noise [m], fraction of samples lost."""

    sample_rate: float = 100.0
    noise: float = 1e-3
    missing: float = 0.0

    def __post_init__(self) -> None:
        if not (self.sample_rate > 0 and self.noise >= 0 and 0 <= self.missing < 0.5):
            raise ValueError(f"invalid observation {self!r}.")


@dataclass(frozen=True)
class Recording:
    """Exact arrays of one run: time (T,), nodes (T x 12 x 3), controls and rest (T x 24) true [m]."""

    time: np.ndarray
    nodes: np.ndarray
    controls: np.ndarray
    rest: np.ndarray
    tension: np.ndarray


def record_flop(robot: CableRobot, flop: Flop, *, duration: float = 3.0, sample_rate: float = 100.0) -> Recording:
    """Run one flop from the robot's present state; commands are held between samples."""
    substeps = int(round(1.0 / (sample_rate * robot.dt)))
    n = int(round(duration * sample_rate)) + 1
    planner = FlopPlanner(flop)
    planner.plan(robot)
    out = {k: np.empty((n, 24)) for k in ("controls", "rest", "tension")}
    nodes = np.empty((n, 12, 3))
    for i in range(n):
        nodes[i] = robot.nodes()
        out["rest"][i] = robot.rest
        out["tension"][i] = robot.tensions()
        out["controls"][i] = planner.targets(i / sample_rate)
        if i < n - 1:
            for _ in range(substeps):
                robot.step(out["controls"][i])
            robot.check()
    return Recording(np.arange(n) / sample_rate, nodes, out["controls"], out["rest"], out["tension"])


def to_dataset(rec: Recording, robot: CableRobot, obs: Observation, rng: np.random.Generator, *,
               attrs: dict[str, object]) -> xr.Dataset:
    """The recording as a trajectory Dataset, observed through ``obs`` and the robot's effects."""
    nodes = rec.nodes + np.asarray(robot.effects.marker_offset)
    nodes = nodes + rng.normal(0.0, obs.noise, nodes.shape) if obs.noise > 0 else nodes.copy()
    lost = rng.random(len(rec.time)) < obs.missing
    lost[0] = False
    nodes[lost] = np.nan
    zero = robot.encoder_offset
    cable = cable_names()
    ds = xr.Dataset(
        {
            "nodes": (("time", "node", "axis"), nodes, {"units": "m"}),
            "controls": (("time", "cable"), rec.controls - zero, {"units": "m"}),
            "rest_length": (("time", "cable"), rec.rest - zero, {"units": "m"}),
        },
        coords={"time": ("time", rec.time, {"units": "s"}), "node": np.arange(12), "axis": ["x", "y", "z"],
                "cable": cable, "end_a": ("cable", CABLE_ENDS[:, 0]), "end_b": ("cable", CABLE_ENDS[:, 1])},
        attrs={"format": "tensegrid-trajectory-1", "robot": "SUPERball T6", "length_reference": "encoder",
               "source": f"testbed: SUPERball in {robot.engine_name} (benchmarks/testbed)", "noise_m": obs.noise,
               "testbed_theta": json.dumps(robot.theta), "testbed_effects": json.dumps(robot.effects.active()),
               **attrs},
    )
    return ds
