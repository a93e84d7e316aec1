"""Calibration of the verdicts on the T6: do identified intervals hold the truth?

For each problem, θ* is drawn uniformly from the ±10 % box and a flop (3 s, 100 Hz, heading drawn
per problem) is recorded with 1 mm sensor noise, by one of these data-generating models:

- ``testbed1``, ``testbed3``: the foreign robot (benchmarks/testbed, a SUPERball in Bullet that
  shares no code with the library): the ``perturbed`` data set of seed = problem (its 12 active
  parameters drawn within ±10 %, the three motor parameters inert), its first flop or all three;
- ``mujoco1``, ``mujoco3``: the same robots and flops in MuJoCo (benchmarks/testbed/mujoco_robot.py,
  the third engine), which no choice of this library was tuned on;
- ``native1``, ``native3``: the same robots and flops on the SUPERball rebuilt with MuJoCo's own
  tendons and winches (benchmarks/testbed/mujoco_native.py), which shares no robot code;
- ``own``: this project's model, as the identifier assumes it;
- ``mismatch``: a deliberately different model the identifier is not told about: physics step
  0.5 ms instead of 1 ms, ground friction 0.8 instead of 0.5, rod spin damping 0.5 instead of
  2 N·m·s, and a slower, stiffer motor driver (kp 5 /s instead of 10, kv 0.1 instead of 0.05).

Identification: full-space BO (Identity decoder, 4096 Sobol candidates, seed = problem) with the
likelihood posterior. Each problem runs once with the largest budget and a journal; smaller
budgets are the same run's first evaluations, replayed from the journal (identify is deterministic,
so a shorter run is exactly a prefix).

Per scenario and budget it prints: parameters flagged identified, how many of their 90 % intervals
hold θ* (target >= 90 %), the largest distance from θ* to an identified interval in interval
widths (target <= 3), how many intervals of parameters called identified or weakly identified
miss the best evaluated θ (target 0: P must not contradict its evaluations), and the median
interval width per parameter in % of the prior box, and per problem the parameters it called
identified or weakly identified.

    .venv/bin/python benchmarks/calibration_t6.py --scenarios testbed1 testbed3 --problems 10 --budgets 60
    .venv/bin/python benchmarks/calibration_t6.py --scenarios mujoco1 --problems 10 --budgets 60 --first-seed 0
    .venv/bin/python benchmarks/calibration_t6.py                      # 20 problems, budgets 40 and 120
    .venv/bin/python benchmarks/calibration_t6.py --problems 4 --budgets 30 --rule iid   # quick, old rule
    .venv/bin/python benchmarks/calibration_t6.py --bias --problems 3 --budgets 60       # the shared bias

``--read-actuator`` identifies as ``tensegrid identify`` does on data with encoder readings: the
actuator law read from them replaces the motor model when it fits them ten times better
(physics.actuator_choice), and the motor parameters it makes inert are held at nominal (verdict
"inert", no interval; left out of the counts).

``--bias`` prints, per problem, how much worse θ* fits each of 6 segments than the best evaluated θ
(in % of that segment's error): a bias all segments share is what the discrepancy floor δ_0 of
the "ess" noise rule covers (docs/identification.md).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from belief import PosteriorConfig, SobolCandidates, identify
from embeddings import Identity
from physics import (
    FlopController, ModelOptions, MotorGains, ParameterSpace, TrajectoryObjective, load_trajectory, simulate,
)

SCENARIOS = ("testbed1", "testbed3", "mujoco1", "mujoco3", "native1", "native3", "own", "mismatch")
ENGINE_OF = {"testbed": "bullet", "mujoco": "mujoco", "native": "mujoco-native"}
#: the verdict of a parameter held because the measured actuator makes it inert (--read-actuator)
INERT = "inert"
MISMATCH = ModelOptions(dt=5e-4, friction=0.8, spin_damping=0.5, motor=MotorGains(kp=5.0, kv=0.1))


@dataclass
class Outcome:
    """One identification: per parameter the truth, interval (lower, upper), verdict, and the flag of
    the previous release (``narrow``: posterior std < half the prior's, nothing else checked)."""

    truth: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    verdict: list[str]
    narrow: np.ndarray | None = None
    best: np.ndarray | None = None


def testbed_data(seed: int, flops: int, *, noise: float = 1e-3, engine: str = "bullet"):
    """(θ*, the first ``flops`` flops) of the testbed's ``perturbed`` data set at ``seed``, recorded in
    ``engine`` ("bullet" or "mujoco")."""
    from testbed.datasets import cached_dataset
    files = cached_dataset("perturbed", seed, noise=noise, engine=engine)
    truth = json.loads((files["flop_0"].parent / "truth.json").read_text())
    theta = ParameterSpace.t6().as_array(truth["theta"])
    return theta, [load_trajectory(files[f"flop_{k}"]) for k in range(flops)]


def problem_data(seed: int, scenario: str, *, duration: float = 3.0, noise: float = 1e-3):
    """(θ*, flop trajectory or trajectories) of problem ``seed`` under ``scenario``."""
    if scenario[:-1] in ENGINE_OF:
        return testbed_data(seed, int(scenario[-1]), noise=noise, engine=ENGINE_OF[scenario[:-1]])
    space = ParameterSpace.t6()
    theta = space.sample(1, seed=seed)[0]
    heading = float(np.random.default_rng([seed, 7]).uniform(-np.pi, np.pi))
    options = MISMATCH if scenario == "mismatch" else None
    data = simulate(theta, controller=FlopController(heading=heading), duration=duration, options=options,
                    noise=noise, seed=seed)
    return theta, data


def model_objective(data, read_actuator: bool):
    """The objective of ``data``: the T6, or with ``read_actuator`` the model ``tensegrid identify``
    builds from encoder readings, its inert parameters held (module docstring)."""
    if not read_actuator:
        return TrajectoryObjective(data, loss="squared", n_workers=0)
    from physics.actuator_choice import choose_actuator
    from physics.measurements import MeasurementPrior

    space = ParameterSpace.t6()
    choice = choose_actuator(data if isinstance(data, list) else [data], space)
    effects = (choice.effect,) if choice is not None and choice.effect is not None else ()
    known = MeasurementPrior(space).with_inert(choice.inert if effects else ())
    return known.hold(TrajectoryObjective(data, loss="squared", n_workers=0, effects=effects))


def _outcome(theta: np.ndarray, res) -> Outcome:
    """The Outcome of one result over the T6's 15 parameters, those it held without an interval."""
    names, m = ParameterSpace.t6().names, res.belief.marginals()
    free = [names.index(str(n)) for n in m["parameter"].values]
    lower, upper, best = (np.full(len(names), np.nan) for _ in range(3))
    verdict, narrow = [INERT] * len(names), np.zeros(len(names), bool)
    lower[free], upper[free], best[free] = m["lower"].values, m["upper"].values, np.asarray(res.best_theta.values)
    narrow[free] = m["std"].values < 0.5 * m["prior_std"].values
    for j, v in zip(free, m["verdict"].values, strict=True):
        verdict[j] = str(v)
    return Outcome(theta, lower, upper, verdict, narrow, best)


def identify_problem(seed: int, scenario: str, budgets: list[int], *, rule: str = "ess", candidates: int = 4096,
                     duration: float = 3.0, workdir: str | None = None, discrepancy: float = 0.05,
                     journals: str | None = None, read_actuator: bool = False) -> dict[int, Outcome]:
    """Outcomes of problem ``seed`` at each budget (one run, smaller budgets replayed from its journal;
    ``journals``: a folder that keeps the journals, so another posterior setting replays the same run)."""
    theta, data = problem_data(seed, scenario, duration=duration)
    objective = model_objective(data, read_actuator)
    decoder = Identity(objective.space)
    grid = SobolCandidates.for_decoder(decoder, n=candidates, seed=seed)
    cfg = PosteriorConfig(noise_rule=rule, discrepancy=discrepancy)
    out: dict[int, Outcome] = {}
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        tag = "-read" if read_actuator else ""
        journal = os.path.join(journals or tmp, f"{scenario}-{seed}-{max(budgets)}{tag}.sqlite")
        for budget in sorted(budgets, reverse=True):
            res = identify(objective, decoder, grid, budget=budget, seed=seed, journal=journal, progress=False,
                           posterior=cfg)
            out[budget] = _outcome(theta, res)
    return out


def shared_bias(seed: int, scenario: str, budget: int, *, windows: int = 6) -> np.ndarray:
    """(E_s(θ*) − E_s(θ̂)) / E_s(θ̂) per segment s (%), θ̂ the best of ``budget`` BO evaluations."""
    theta, data = problem_data(seed, scenario)
    space = ParameterSpace.t6()
    objective = TrajectoryObjective(data, loss="squared", n_workers=0, windows=windows)
    decoder = Identity(space)
    grid = SobolCandidates.for_decoder(decoder, n=4096, seed=seed)
    res = identify(objective, decoder, grid, budget=budget, seed=seed, progress=False, posterior=None)
    best = objective.evaluate_parts(res.best_theta.values)
    return 100.0 * (objective.evaluate_parts(theta) - best) / best


def score(outcomes: list[Outcome], *, old_flag: bool = False) -> dict[str, float]:
    """Identified count, coverage of identified intervals, worst miss in widths (inf: a zero-width
    interval that misses), mean identified per problem; ``old_flag``: count the previous release's flag (``narrow``) instead of the verdicts."""
    n_id = hit = 0
    worst = 0.0
    for o in outcomes:
        flags = o.narrow if old_flag else [v == "identified" for v in o.verdict]
        for j, flagged in enumerate(flags):
            if not flagged:
                continue
            n_id += 1
            width = o.upper[j] - o.lower[j]
            miss = max(o.lower[j] - o.truth[j], o.truth[j] - o.upper[j], 0.0)
            hit += miss == 0.0
            worst = max(worst, 0.0 if miss == 0.0 else miss / width if width > 0 else np.inf)
    return {"identified": n_id, "covered": hit, "coverage": hit / n_id if n_id else float("nan"),
            "worst_widths": worst, "per_problem": n_id / max(len(outcomes), 1),
            "claimed": sum(v not in ("not identified", INERT) for o in outcomes for v in o.verdict),
            "miss_best": sum(len(misses_best(o)) for o in outcomes),
            "holding": sum(int(np.sum((o.lower <= o.truth) & (o.truth <= o.upper))) for o in outcomes),
            "intervals": sum(v != INERT for o in outcomes for v in o.verdict)}


def misses_best(o: Outcome) -> list[int]:
    """Parameters called identified or weakly identified whose interval misses the best evaluated θ."""
    if o.best is None:
        return []
    return [j for j, v in enumerate(o.verdict)
            if v not in ("not identified", INERT) and not o.lower[j] <= o.best[j] <= o.upper[j]]


def claimed_names(outcomes: list[Outcome], names: Sequence[str], first_seed: int) -> str:
    """``"seed: name, name (weakly); ..."``: per problem the parameters called identified, or weakly
    identified, ``-`` where none is."""
    parts = []
    for k, o in enumerate(outcomes):
        said = [f"{n}{'' if v == 'identified' else ' (weakly)'}" for n, v in zip(names, o.verdict, strict=True)
                if v not in ("not identified", INERT)]
        parts.append(f"{first_seed + k}: {', '.join(said) or '-'}")
    return "; ".join(parts)


def width_table(outcomes: list[Outcome]) -> np.ndarray:
    """Median 90 % interval width per parameter, in % of the prior box (D,; NaN where held inert)."""
    space = ParameterSpace.t6()
    w = np.array([(o.upper - o.lower) / (space.upper - space.lower) for o in outcomes])
    held = np.isnan(w).all(axis=0)
    return 100.0 * np.where(held, np.nan, np.median(np.where(np.isnan(w), np.inf, w), axis=0))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--problems", type=int, default=20)
    p.add_argument("--budgets", type=int, nargs="+", default=[40, 120])
    p.add_argument("--scenarios", nargs="+", default=list(SCENARIOS), choices=SCENARIOS)
    p.add_argument("--rule", choices=["ess", "iid"], default="ess", help="noise rule of the likelihood posterior")
    p.add_argument("--first-seed", type=int, default=100)
    p.add_argument("--discrepancy", type=float, default=PosteriorConfig().discrepancy,
                   help="δ_0 of the 'ess' noise rule (belief.noise)")
    p.add_argument("--journals", default=None, help="keep the runs' journals here (a rerun replays them)")
    p.add_argument("--bias", action="store_true", help="print the per-segment excess error of the truth instead")
    p.add_argument("--read-actuator", action="store_true",
                   help="identify with the actuator read from the encoder readings, as tensegrid identify does")
    args = p.parse_args(argv)
    space = ParameterSpace.t6()
    from tqdm.auto import tqdm

    if args.bias:
        for scenario in args.scenarios:
            for k in range(args.problems):
                excess = shared_bias(args.first_seed + k, scenario, max(args.budgets))
                print(f"{scenario:9s} problem {args.first_seed + k}: E_s(truth) exceeds E_s(best) by "
                      + ", ".join(f"{v:+.1f}%" for v in excess), flush=True)
        return 0

    for scenario in args.scenarios:
        if args.journals:
            os.makedirs(args.journals, exist_ok=True)
        runs = [identify_problem(args.first_seed + k, scenario, args.budgets, rule=args.rule,
                                 discrepancy=args.discrepancy, journals=args.journals,
                                 read_actuator=args.read_actuator)
                for k in tqdm(range(args.problems), desc=scenario)]
        for budget in sorted(args.budgets):
            outs = [r[budget] for r in runs]
            s = score(outs)
            print(f"{scenario:9s} rule={args.rule} budget={budget:4d} problems={len(outs)}: identified {s['identified']} "
                  f"({s['per_problem']:.2f} per problem), covered {s['covered']} = {s['coverage']:.0%}, "
                  f"worst miss {s['worst_widths']:.2f} widths; identified or weakly: {s['claimed']}, "
                  f"of which miss the best evaluation: {s['miss_best']}; every interval holding θ*: "
                  f"{s['holding']} of {s['intervals']}", flush=True)
            old = score(outs, old_flag=True)
            print(f"    previous flag (std < prior std / 2) on the same P: identified {old['identified']}, covered "
                  f"{old['covered']} = {old['coverage']:.0%}, worst miss {old['worst_widths']:.2f} widths", flush=True)
            widths = width_table(outs)
            print("    median 90% width, % of box: " + ", ".join(
                f"{n} {w:.0f}" for n, w in zip(space.names, widths)), flush=True)
            print("    identified or weakly, per problem: " + claimed_names(outs, space.names, args.first_seed),
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
