"""Named data sets of the testbed robot: each one robot, three flops and a held-out flop.

A data set's robot moves in one of three engines (``ENGINES``): ``bullet`` (the testbed, the
default), ``mujoco`` (a third engine, held back; docs/third-engine.md) or ``mujoco-native`` (the
hardware rebuilt in MuJoCo's own tendons and pid winches, sharing no robot code:
testbed.mujoco_native; it has no drag, hysteresis or ground viscosity). The robot, the flops'
plans (headings, actuation) and the noise are the same in all; the rigid bodies, contact and
integration differ (and in ``mujoco-native`` the cables and actuators), and so may the cables
the controller picks by trial on the robot.

A data set is one robot (θ and effects) settled for 3 s on a face; from that same rest state it
makes three flops toward headings 120° apart (rotated by an angle drawn from the seed) and one
held-out flop with another actuation, heading between two of the others. Files: ``flop_0.nc``,
``flop_1.nc``, ``flop_2.nc``, ``heldout_0.nc`` and ``truth.json`` (θ, effects, seed, flops'
version). Same name, seed and version, same files.

The flops come in two versions (``FLOP_VERSIONS``):

- 1: every flop shortens and lengthens 4 cables by 30 % from 0.2 to 1.2 s, the held-out flop 5
  cables by 25 % from 0.3 to 1.1 s. A heading picks one of the three edges of the base triangle,
  so on a robot that does not change with the seed, the seeds replay the same flops
  (benchmarks/testbed_flops.py counts them);
- 2: each flop's actuation is drawn from the seed: change 20-35 % (held-out: 15-30 %), 3-5 cables
  per side (held-out: 4-6), start 0.15-0.35 s, held for 0.7-1.1 s.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np

from testbed.cable_robot import CableRobot
from testbed.controller import Flop
from testbed.effects import Effects
from testbed.params import NOMINAL, draw_theta
from testbed.record import Observation, record_flop, to_dataset
from testbed.robot import TestbedRobot

__all__ = ["DATASETS", "STREAMS", "ENGINES", "FLOP_VERSIONS", "Robot", "robot_for", "flops_for", "make_dataset",
           "cached_dataset", "build_robot", "SETTLE_S"]

SETTLE_S = 3.0
FLOP_VERSIONS = (1, 2)
ENGINES = ("bullet", "mujoco", "mujoco-native")


@dataclass(frozen=True)
class Robot:
    """What a data set's robot is: θ (15 names, SI) and its hidden effects."""

    theta: dict
    effects: Effects


def _slope(rng: np.random.Generator) -> Effects:
    return Effects(slope=float(np.deg2rad(3.0)), slope_azimuth=float(rng.uniform(0, 2 * np.pi)))


def _slope_and_delay(rng: np.random.Generator) -> Effects:
    return replace(_slope(rng), actuator_delay=0.05)


def _mass(rng: np.random.Generator) -> Effects:
    return Effects(extra_mass=0.5, extra_mass_rod=int(rng.integers(6)), extra_mass_at=0.4)


#: name -> (draws θ*?, the effects given the seed's generator)
DATASETS: dict[str, tuple[bool, Callable[[np.random.Generator], Effects]]] = {
    "nominal": (False, lambda rng: Effects()),
    "perturbed": (True, lambda rng: Effects()),
    "slope": (False, _slope),
    "marker_offset": (False, lambda rng: Effects(marker_offset=(0.02, -0.015, 0.01))),
    "drag": (False, lambda rng: Effects(drag=3.0)),
    "actuator_delay": (False, lambda rng: Effects(actuator_delay=0.05)),
    "hysteresis": (False, lambda rng: Effects(hysteresis=0.3)),
    "extra_mass": (False, _mass),
    "ground_viscosity": (False, lambda rng: Effects(ground_viscosity=20.0)),
    "slope+delay": (False, _slope_and_delay),
    "drag+hysteresis": (False, lambda rng: Effects(drag=3.0, hysteresis=0.3)),
}
#: data set -> the index of its generator's stream, [seed, index]; a new data set takes the next
#: index, so adding one changes no other data set's robot, flops or noise
STREAMS = {name: k for k, name in enumerate((
    "actuator_delay", "drag", "extra_mass", "ground_viscosity", "hysteresis", "marker_offset", "nominal",
    "perturbed", "slope", "slope+delay", "drag+hysteresis"))}


def robot_for(name: str, seed: int) -> tuple[Robot, np.random.Generator]:
    """The robot of data set ``name`` at ``seed`` and the generator that goes on to draw the rest."""
    if name not in DATASETS:
        raise KeyError(f"unknown testbed data set {name!r}; choose from {sorted(DATASETS)}.")
    rng = np.random.default_rng([seed, STREAMS[name]])
    perturbed, effects = DATASETS[name]
    theta = draw_theta(rng) if perturbed else dict(NOMINAL)
    return Robot(theta, effects(rng)), rng


def _drawn(rng: np.random.Generator, heading: float, change: tuple[float, float], cables: tuple[int, int]) -> Flop:
    """A flop toward ``heading`` whose change, cables per side, start and hold time are drawn (version 2)."""
    start = float(rng.uniform(0.15, 0.35))
    return Flop(heading=heading, change=float(rng.uniform(*change)),
                n_cables=int(rng.integers(cables[0], cables[1] + 1)), start=start,
                stop=start + float(rng.uniform(0.7, 1.1)))


def flops_for(rng: np.random.Generator, version: int = 1) -> dict[str, Flop]:
    """The three flops and the held-out flop of a data set (headings rotated by the seed; the
    actuation fixed in version 1, drawn in version 2: module docstring)."""
    if version not in FLOP_VERSIONS:
        raise ValueError(f"unknown flops version {version!r}; choose from {FLOP_VERSIONS}.")
    offset = float(rng.uniform(0, 2 * np.pi))
    if version == 1:
        flops = {f"flop_{k}": Flop(heading=offset + 2 * np.pi * k / 3) for k in range(3)}
        flops["heldout_0"] = Flop(heading=offset + np.pi / 3, change=0.25, n_cables=5, start=0.3, stop=1.1)
        return flops
    flops = {f"flop_{k}": _drawn(rng, offset + 2 * np.pi * k / 3, (0.2, 0.35), (3, 5)) for k in range(3)}
    flops["heldout_0"] = _drawn(rng, offset + np.pi / 3, (0.15, 0.3), (4, 6))
    return flops


def build_robot(robot: Robot, engine: str = "bullet", *, ground_rolling: float = 1.0) -> CableRobot:
    """The robot in ``engine`` (one of ``ENGINES``); ``ground_rolling``: Bullet's ground rolling
    friction (TestbedRobot; ablations only)."""
    if engine == "bullet":
        return TestbedRobot(robot.theta, robot.effects, ground_rolling=ground_rolling)
    if engine == "mujoco":
        from testbed.mujoco_robot import MujocoRobot
        if ground_rolling != 1.0:
            raise ValueError("ground_rolling is Bullet's; the MuJoCo robot has no rolling friction.")
        return MujocoRobot(robot.theta, robot.effects)
    if engine == "mujoco-native":
        from testbed.mujoco_native import NativeMujocoRobot
        if ground_rolling != 1.0:
            raise ValueError("ground_rolling is Bullet's; the mujoco-native robot has no rolling friction.")
        return NativeMujocoRobot(robot.theta, robot.effects)
    raise ValueError(f"unknown engine {engine!r}; choose from {ENGINES}.")


def make_dataset(name: str, seed: int, out: "str | Path", *, obs: Observation = Observation(),
                 duration: float = 3.0, effects: Effects | None = None, version: int = 1,
                 ground_rolling: float = 1.0, engine: str = "bullet") -> list[Path]:
    """Write data set ``name`` for ``seed`` into folder ``out``; returns the trajectory files.
    ``effects`` replaces the data set's own (for combinations); ``version``: of the flops;
    ``ground_rolling``: the ground's rolling friction (Bullet; ablations only); ``engine``: of ``ENGINES``."""
    robot_def, rng = robot_for(name, seed)
    if effects is not None:
        robot_def = replace(robot_def, effects=effects)
    robot = build_robot(robot_def, engine, ground_rolling=ground_rolling)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    try:
        for _ in range(int(round(SETTLE_S / robot.dt))):
            robot.step(robot.rest)
        settled = robot.snapshot()
        paths = []
        for k, (label, flop) in enumerate(flops_for(rng, version).items()):
            robot.restore(settled)
            rec = record_flop(robot, flop, duration=duration, sample_rate=obs.sample_rate)
            ds = to_dataset(rec, robot, obs, np.random.default_rng([seed, k, 7]),
                            attrs={"testbed_dataset": name, "testbed_seed": seed, "testbed_flop": repr(flop)})
            paths.append(out / f"{label}.nc")
            ds.to_netcdf(paths[-1])
        truth = {"dataset": name, "seed": seed, "theta": robot.theta, "effects": robot.effects.active(),
                 "flops_version": version, "engine": engine}
        (out / "truth.json").write_text(json.dumps(truth, indent=1))
        return paths
    finally:
        robot.close()


def cached_dataset(name: str, seed: int, *, noise: float = 1e-3, missing: float = 0.0,
                   root: "str | Path" = Path(".cache") / "testbed", version: int = 1,
                   engine: str = "bullet") -> dict[str, Path]:
    """The files of data set ``name`` at ``seed`` (label -> path), made on first use under ``root``
    (a folder per name, seed, observation, flops' version and engine, ignored by git)."""
    folder = Path(root) / (f"{name}-s{seed}-n{noise:g}" + (f"-m{missing:g}" if missing else "")
                           + (f"-v{version}" if version != 1 else "") + (f"-{engine}" if engine != "bullet" else ""))
    labels = ("flop_0", "flop_1", "flop_2", "heldout_0")
    if not all((folder / f"{label}.nc").exists() for label in labels):
        make_dataset(name, seed, folder, obs=Observation(noise=noise, missing=missing), version=version,
                     engine=engine)
    return {label: folder / f"{label}.nc" for label in labels}
