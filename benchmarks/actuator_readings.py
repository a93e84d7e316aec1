"""The actuator stage on encoder readings (synthetic, the testbed's, the library's): is the law read back?

Commands are flops as a flop controller makes them: half of 8 cables shortened and half lengthened
by ``change`` (20 %) from ``start`` to ``stop`` (0.2 s to 1.2 s), the others held. Readings come from
an actuator simulated independently of physics.actuator_laws, in physics steps of 1 ms as the
Bullet testbed writes its actuator (benchmarks/testbed/cable_robot.py): a delay line of whole
steps, then each step the rest length moves toward its (floored) target by at most rate · 1 ms,
then a first-order lag; the encoder adds its offset and Gaussian noise. Printed: per case over 10
seeds, in how many the delay is found within one sample and claimed (or, without a delay, not
claimed), the median delay error [samples], the rate's median and largest relative error, in how
many exactly the offset cable is reported (within 1 mm; none when there is none), the law chosen
most often and the time per identification.

``--engine bullet mujoco`` measures the stage on the foreign robot instead (benchmarks/testbed, in
Bullet or MuJoCo; its actuator is NTRT's basic one: a rate limit ``targetVelocity`` and a tension
limit maxTens / k, testbed.cable_robot), on the data sets ``nominal`` and ``actuator_delay``
(commands reach the actuators 50 ms late), ``--seeds`` seeds each (``--quick``: 3), from the three
fit flops' ``controls`` and ``rest_length`` alone (0.2 mm node noise, flops of version 2: drawn
per seed, so every seed is a new experiment; testbed.datasets caches them under .cache/testbed).
Scored against the testbed's own θ and effects (truth.json): the delay found within one sample
and claimed iff delayed, the rate's error against targetVelocity, the tension slack's against
maxTens / k (the stage measures lengths node to node, the testbed anchor to anchor on the end
faces' rims, so a few mm apart), the law chosen, how often the law was reported as a misfit, the
readings' RMS residual, the time per identification and per data set made ("cached": none made).
``--engine mujoco-native`` does the same on the robot rebuilt with MuJoCo's own tendons and
actuators (testbed.mujoco_native: a rate-limited pid winch, shares no robot code). ``--engine library`` does the same on the library's own robot and motor (physics.actuators: a
driven spool whose speed droops with the cable's tension, outside every law of the stage), three
flops drawn per seed like the testbed's, with and without the ActuatorDelay effect at 50 ms.

    python benchmarks/actuator_readings.py [--seeds 10]
    python benchmarks/actuator_readings.py --engine bullet mujoco [--quick]
    python benchmarks/actuator_readings.py --engine library
    python benchmarks/actuator_readings.py --engine bullet mujoco library --choice

``--choice`` prints, per robot and data set, in how many seeds the law read from the encoders
replaces the motor model in identify and diagnose (physics.actuator_choice: when its RMS residual
on the readings is under a tenth of the motor model's at nominal θ), both residuals, and the delay the
model then carries.
"""
from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import xarray as xr

from physics.actuator_readings import ActuatorConfig, identify_actuator
from physics.actuator_summary import ActuatorFit
from physics.geometry import node_positions
from physics.trajectory import make_trajectory

__all__ = ["Actuator", "flop_commands", "encoder_readings", "as_dataset", "CASES", "run_case", "TESTBED_SETS",
           "testbed_truth", "run_testbed"]

ACTUATED = (3, 5, 7, 11, 13, 15, 17, 18)


@dataclass(frozen=True, kw_only=True)
class Actuator:
    """The simulated actuator: ``delay`` [s] (whole physics steps), ``rate`` [m/s] (inf: none),
    ``time_constant`` [s] (0: none), ``slack`` s [m]: rest lengths never below ℓ - s (inf: none),
    ``offset`` [m] on cable ``offset_cable`` (a mis-zeroed encoder), encoder ``noise`` sd [m]."""

    delay: float = 0.0
    rate: float = np.inf
    time_constant: float = 0.0
    slack: float = np.inf
    offset: float = 0.0
    offset_cable: int = 3
    noise: float = 3e-4


def flop_commands(rng: np.random.Generator, *, samples: int = 250, sample_rate: float = 100.0,
                  change: float = 0.2, start: float = 0.2, stop: float = 1.2,
                  cables: tuple[int, ...] = ACTUATED) -> np.ndarray:
    """Commands (samples x 24) [m]: rest lengths drawn in [0.8, 1.2] m; ``cables`` alternately
    shortened and lengthened by ``change`` between ``start`` and ``stop`` [s]."""
    base = rng.uniform(0.8, 1.2, 24)
    commands = np.tile(base, (samples, 1))
    t = np.arange(samples) / sample_rate
    on = (t >= start) & (t < stop)
    for k, j in enumerate(cables):
        commands[on, j] *= 1 - change if k % 2 == 0 else 1 + change
    return commands


def encoder_readings(commands: np.ndarray, actuator: Actuator, rng: np.random.Generator, *,
                     sample_rate: float = 100.0, lengths: np.ndarray | None = None, step: float = 1e-3
                     ) -> np.ndarray:
    """Readings (T x 24) [m] of ``actuator`` driven by ``commands`` (T x 24), each held for one
    sample interval and simulated in steps of ``step`` [s] (module docstring); ``lengths`` (T x 24)
    [m] the cable lengths its tension limit sees."""
    n, m = commands.shape
    sub = int(round(1.0 / (sample_rate * step)))
    offsets = np.zeros(m)
    offsets[actuator.offset_cable] = actuator.offset
    lengths = np.full((n, m), -np.inf) if lengths is None else lengths
    lag = int(round(actuator.delay / step))
    line = [commands[0] + offsets] * lag
    v = np.maximum(commands[0] + offsets, lengths[0] - actuator.slack)
    rest = v.copy()
    decay = 0.0 if actuator.time_constant == 0 else np.exp(-step / actuator.time_constant)
    out = np.empty((n, m))
    out[0] = rest
    for i in range(n - 1):
        for _ in range(sub):
            line.append(commands[i] + offsets)
            target = np.maximum(line.pop(0), lengths[i] - actuator.slack)
            v = v + np.clip(target - v, -actuator.rate * step, actuator.rate * step)
            rest = v + (rest - v) * decay
        out[i + 1] = rest
    return out + rng.normal(0.0, actuator.noise, out.shape)


def as_dataset(commands: np.ndarray, readings: np.ndarray, *, sample_rate: float = 100.0) -> xr.Dataset:
    """A trajectory with these commands and readings; the robot stands still (upright T6, 1 m up)."""
    nodes = np.tile(node_positions(1.5, 0.375) + [0.0, 0.0, 1.0], (commands.shape[0], 1, 1))
    return make_trajectory(np.arange(commands.shape[0]) / sample_rate, nodes, commands, rest_length=readings)


CASES = {
    "delay 50 ms + rate 1.4 m/s": Actuator(delay=0.05, rate=1.4),
    "delay 25 ms + rate 1.4 m/s": Actuator(delay=0.025, rate=1.4),
    "rate 1.4 m/s (nominal)": Actuator(rate=1.4),
    "lag 30 ms + rate 1.4 m/s": Actuator(time_constant=0.03, rate=1.4),
    "delay 50 ms + lag 20 ms + rate 1.0 m/s": Actuator(delay=0.05, time_constant=0.02, rate=1.0),
    "delay 50 ms + rate 1.4 m/s, offset 15 mm": Actuator(delay=0.05, rate=1.4, offset=0.015),
}


def _scored(fit: ActuatorFit, truth: Actuator, seconds: float) -> dict[str, float | str | bool]:
    """One identification against the truth: delay found [s] (0 unless claimed) and its error
    [samples], claimed, rate and slack errors (relative; NaN without a true one), law, RMS [m],
    misfit reported, time [s]."""
    delay = fit.delay.value if fit.delay is not None and fit.delay_claimed else 0.0
    rate = fit.rate.value if fit.rate is not None else np.inf
    slack = fit.tension_slack.value if fit.tension_slack is not None else np.inf
    return {"delay": delay, "delay_error": abs(delay - truth.delay) / fit.interval, "claimed": fit.delay_claimed,
            "rate_error": abs(rate / truth.rate - 1) if np.isfinite(truth.rate) else np.nan,
            "slack_error": abs(slack / truth.slack - 1) if np.isfinite(truth.slack) else np.nan,
            "law": fit.form, "rms": fit.rms, "seconds": seconds,
            "misfit": any(f.code == "actuator_law_misfit" for f in fit.findings)}


def run_case(actuator: Actuator, seed: int) -> dict[str, float | str | bool]:
    """Identify one seed of a case: :func:`_scored`, and whether exactly the offset cable is reported."""
    rng = np.random.default_rng(seed)
    commands = flop_commands(rng)
    ds = as_dataset(commands, encoder_readings(commands, actuator, rng))
    began = time.perf_counter()
    fit = identify_actuator([ds], ActuatorConfig())
    row = _scored(fit, actuator, time.perf_counter() - began)
    expected = (actuator.offset_cable,) if actuator.offset else ()
    row["offsets_right"] = fit.offset_cables == expected and all(
        abs(fit.offsets[j] - actuator.offset) < 1e-3 for j in expected)
    return row


#: The testbed data sets measured: the nominal robot, and commands reaching the actuators 50 ms late.
TESTBED_SETS = ("nominal", "actuator_delay")


def testbed_truth(folder: Path) -> Actuator:
    """The testbed actuator behind a data set (its truth.json): delay [s], rate targetVelocity [m/s],
    slack maxTens / k [m]."""
    truth = json.loads((folder / "truth.json").read_text())
    theta = truth["theta"]
    return Actuator(delay=float(truth["effects"].get("actuator_delay", 0.0)), rate=theta["targetVelocity"],
                    slack=theta["maxTens"] / theta["stiffnessActive"])


def run_testbed(name: str, seed: int, engine: Literal["bullet", "mujoco", "mujoco-native"], *, version: int = 2,
                noise: float = 2e-4) -> dict[str, float | str | bool]:
    """Identify the actuator of testbed data set ``name`` at ``seed`` in ``engine`` from its three fit
    flops (made and cached on first use): :func:`_scored`, and ``made`` the seconds spent making
    the data set (0 when cached)."""
    from testbed.datasets import cached_dataset

    began = time.perf_counter()
    files = cached_dataset(name, seed, noise=noise, version=version, engine=engine)
    made = time.perf_counter() - began
    data = [xr.load_dataset(files[f"flop_{k}"]) for k in range(3)]
    began = time.perf_counter()
    fit = identify_actuator(data, ActuatorConfig())
    row = _scored(fit, testbed_truth(files["flop_0"].parent), time.perf_counter() - began)
    return row | {"made": made if made > 1.0 else 0.0}


def library_flops(name: str, seed: int, *, noise: float = 2e-4) -> tuple[list[xr.Dataset], Actuator]:
    """Three flops of the library's own robot (physics.simulation, its motor physics.actuators) at
    nominal θ, headings h0 + 0°, 120°, 240° with h0, the change (20-35 %), the cables per side (3-5)
    and the start (0.15-0.35 s, held 0.7-1.1 s) drawn from ``seed`` as the testbed's version 2 flops
    are; ``name`` "actuator_delay" adds the ActuatorDelay effect at 50 ms. Returns the flops (2 s,
    ``noise`` on the nodes) and the truth: delay, rate targetVelocity, slack maxTens / k."""
    from physics import FlopController, simulate
    from physics.effects.base import model_space
    from physics.effects.components import ActuatorDelay

    effects = (ActuatorDelay(),) if name == "actuator_delay" else ()
    space = model_space(effects)
    theta = dict(zip(space.names, space.nominal, strict=True)) | ({"actuator_delay": 0.05} if effects else {})
    rng = np.random.default_rng([seed, 68])
    h0, flops = rng.uniform(0.0, 2 * np.pi), []
    for k in range(3):
        start = rng.uniform(0.15, 0.35)
        controller = FlopController(heading=h0 + 2 * np.pi * k / 3, change=rng.uniform(0.2, 0.35),
                                    n_cables=int(rng.integers(3, 6)), start=start, stop=start + rng.uniform(0.7, 1.1))
        flops.append(simulate(theta, controller=controller, duration=2.0, effects=effects, noise=noise,
                              seed=np.random.default_rng([seed, k])))
    truth = Actuator(delay=theta.get("actuator_delay", 0.0), rate=theta["targetVelocity"],
                     slack=theta["maxTens"] / theta["stiffnessActive"])
    return flops, truth


def run_library(name: str, seed: int, *, noise: float = 2e-4) -> dict[str, float | str | bool]:
    """:func:`run_testbed` on the library's own robot (:func:`library_flops`); ``made``: the seconds
    spent simulating the three flops."""
    began = time.perf_counter()
    data, truth = library_flops(name, seed, noise=noise)
    made = time.perf_counter() - began
    began = time.perf_counter()
    fit = identify_actuator(data, ActuatorConfig())
    return _scored(fit, truth, time.perf_counter() - began) | {"made": made}


def _spread(values: list[float], scale: float, digits: int = 2) -> str:
    """``median (min-max)`` of the finite ``values`` times ``scale``, followed by ``, n of N`` when some
    are not finite (a part the law lacks on those seeds); ``-`` when none is."""
    v = scale * np.asarray(values, float)
    ok = v[np.isfinite(v)]
    if not ok.size:
        return "-"
    some = f", {ok.size} of {v.size}" if ok.size < v.size else ""
    return f"{np.median(ok):.{digits}f} ({ok.min():.{digits}f}-{ok.max():.{digits}f}{some})"


def synthetic_table(seeds: int) -> None:
    """The synthetic cases of CASES (module docstring), ``seeds`` seeds each."""
    print("| case | delay right (within 1 sample, claimed iff delayed) | median delay error [samples] | "
          "rate error median / max | offsets right | law chosen most | s per fit |")
    print("|---|---|---|---|---|---|---|")
    for name, actuator in CASES.items():
        rows = [run_case(actuator, seed) for seed in range(seeds)]
        right = sum(r["delay_error"] <= 1.0 and r["claimed"] == (actuator.delay > 0) for r in rows)
        rate = np.array([r["rate_error"] for r in rows], float)
        law, count = Counter(r["law"] for r in rows).most_common(1)[0]
        print(f"| {name} | {right}/{len(rows)} | {np.median([r['delay_error'] for r in rows]):.2f} | "
              f"{100 * np.nanmedian(rate):.2f} % / {100 * np.nanmax(rate):.2f} % | "
              f"{sum(bool(r['offsets_right']) for r in rows)}/{len(rows)} | {law} ({count}) | "
              f"{np.mean([r['seconds'] for r in rows]):.1f} |")


def testbed_table(engines: list[str], seeds: range, version: int, noise: float) -> None:
    """Per engine (a testbed engine or ``library``) and data set of TESTBED_SETS, ``seeds``: the figures of
    the module docstring."""
    print("| engine | data set | delay right (within 1 sample, claimed iff delayed) | delay found [ms] median "
          "(min-max) | rate error [%] median (min-max) | slack error [%] median (min-max) | law chosen most | "
          "misfit reported | readings' RMS [mm] median (min-max) | s per fit | s per data set made |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for engine in engines:
        for name in TESTBED_SETS:
            rows = [run_library(name, seed, noise=noise) if engine == "library" else
                    run_testbed(name, seed, engine, version=version, noise=noise) for seed in seeds]
            delayed = name == "actuator_delay"
            right = sum(r["delay_error"] <= 1.0 and r["claimed"] == delayed for r in rows)
            law, count = Counter(r["law"] for r in rows).most_common(1)[0]
            made = [r["made"] for r in rows if r["made"] > 0]
            print(f"| {engine} | {name} | {right}/{len(rows)} | {_spread([r['delay'] for r in rows], 1e3, 1)} | "
                  f"{_spread([r['rate_error'] for r in rows], 100)} | {_spread([r['slack_error'] for r in rows], 100)}"
                  f" | {law} ({count}) | {sum(bool(r['misfit']) for r in rows)}/{len(rows)} | "
                  f"{_spread([r['rms'] for r in rows], 1e3)} | {np.mean([r['seconds'] for r in rows]):.1f} | "
                  f"{f'{np.mean(made):.0f} ({len(made)} made)' if made else 'cached'} |", flush=True)


def choice_table(engines: list[str], seeds: range, version: int, noise: float) -> None:
    """Per engine and data set of TESTBED_SETS: in how many seeds the law read from the encoders
    replaces the motor model (physics.actuator_choice), and the two RMS residuals on the readings."""
    from physics.actuator_choice import choose_actuator
    from physics.parameters import ParameterSpace

    print("| engine | data set | law replaces the motor | law's RMS [mm] median (min-max) | motor model's RMS at "
          "nominal θ [mm] median (min-max) | delay in the model [ms] median (min-max) |")
    print("|---|---|---|---|---|---|")
    for engine in engines:
        for name in TESTBED_SETS:
            choices = []
            for seed in seeds:
                if engine == "library":
                    data = library_flops(name, seed, noise=noise)[0]
                else:
                    from testbed.datasets import cached_dataset
                    files = cached_dataset(name, seed, noise=noise, version=version, engine=engine)
                    data = [xr.load_dataset(files[f"flop_{k}"]) for k in range(3)]
                choice = choose_actuator(data, ParameterSpace.t6())
                assert choice is not None
                choices.append(choice)
            delays = [c.effect.law.delay if c.effect is not None else np.nan for c in choices]
            print(f"| {engine} | {name} | {sum(c.measured for c in choices)}/{len(choices)} | "
                  f"{_spread([c.law_rms for c in choices], 1e3)} | {_spread([c.motor_rms for c in choices], 1e3)} | "
                  f"{_spread(delays, 1e3, 1)} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--engine", nargs="+", choices=("synthetic", "bullet", "mujoco", "mujoco-native", "library"),
                        default=["synthetic"], help="synthetic readings (CASES), the testbed robot in Bullet or "
                        "MuJoCo, or the library's own robot and motor (physics.simulation)")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--first-seed", type=int, default=0, help="of the testbed data sets")
    parser.add_argument("--quick", action="store_true", help="3 seeds")
    parser.add_argument("--flops-version", type=int, default=2, help="of the testbed's flops (testbed.datasets)")
    parser.add_argument("--noise", type=float, default=2e-4, help="the node noise of the robots' flops [m]")
    parser.add_argument("--choice", action="store_true", help="the robots' tables: which actuator the model takes "
                        "(physics.actuator_choice) instead of the stage's figures")
    args = parser.parse_args()
    seeds = 3 if args.quick else args.seeds
    if args.choice:
        foreign = [e for e in args.engine if e != "synthetic"]
        choice_table(foreign, range(args.first_seed, args.first_seed + seeds), args.flops_version, args.noise)
        return
    if "synthetic" in args.engine:
        synthetic_table(seeds)
    foreign = [e for e in args.engine if e != "synthetic"]
    if foreign:
        testbed_table(foreign, range(args.first_seed, args.first_seed + seeds), args.flops_version, args.noise)


if __name__ == "__main__":
    main()
