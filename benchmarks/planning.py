"""Planning benchmark (issue 10): robust vs nominal vs MAP plans, and active vs random vs default probing.

Per seed s: a hidden θ* drawn in the T6's ±10 % box; a belief from a short identification (one
1.5 s flop at θ* with 1 mm sensor noise, the identity decoder on Sobol candidates, BO with a small
budget); then

1. Planning: from the robot's resting start, a goal ``--distance`` m away in a seeded direction.
   The planners flop the robot at θ* toward it, replanning after each flop, until within
   ``--radius`` or ``--steps`` flops: one robust plan per level α of ``--levels`` (CVaR_α under K
   draws of the belief, P re-weighed by each executed flop unless ``--no-learn``), the plan at the
   nominal θ and the plan at the belief's MAP θ. Printed: the rate of runs that reached the goal,
   the mean number of flops and the mean final distance.
2. Probing: M cells drawn from the belief are the hypotheses. Active probing (largest expected
   information gain), random probing (a uniformly drawn candidate) and repeating the default flop
   (heading 0, change 0.2, 4 cables) each run ``--probes`` experiments on a fresh robot at θ*.
   After each experiment: the entropy of P on the cells, and the held-out error: the P-weighted
   one-step error Σ_i w_i E_i on a held-out flop at θ* (another heading and actuation), relative to
   the best cell's, E_min. Printed: experiments needed to reach entropy <= ``--entropy`` nats and
   held-out error <= (1 + ``--tolerance``) E_min (runs that never reach count as probes + 1, and
   the number that reached is shown).

Run::

    .venv/bin/python benchmarks/planning.py --seeds 4            # the modest size of docs/benchmarks.md
    .venv/bin/python benchmarks/planning.py --seeds 8 --parts plan --levels 0.2 0.5 --out FILE   # risk levels
    .venv/bin/python benchmarks/planning.py --quick              # smoke run (1 seed, tiny)
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from belief import SobolCandidates, identify
from embeddings import Identity
from physics import FlopController, ParameterSpace, TrajectoryObjective, simulate
from physics.pool import DaskPool
from planners import FlopAction, PointBelief, SimulatedRobot, plan_to_goal, probe
from planners.rollouts import warm_up

#: the point-belief planners every robust planner is compared with
POINT_PLANNERS = ("nominal", "MAP")


def planner_names(levels: list[float], points: bool = True) -> list[str]:
    """One robust planner per CVaR level α (``robust α=0.2``), then the point planners (if ``points``)."""
    return [f"robust α={a:g}" for a in levels] + (list(POINT_PLANNERS) if points else [])


DEFAULT_FLOP = FlopAction(0.0, 0.2, 4, start=0.2, stop=1.2, duration=1.5)


def make_belief(theta: np.ndarray, seed: int, *, candidates: int, budget: int):
    """A belief from a short identification on one 1.5 s flop at θ (1 mm noise)."""
    data = simulate(theta, controller=FlopController(float(np.random.default_rng(seed).uniform(0, 2 * np.pi))),
                    duration=1.5, noise=1e-3, seed=seed)
    with TrajectoryObjective(data, loss="squared", n_workers=0) as E:
        dec = Identity(E.space)
        res = identify(E, dec, SobolCandidates.for_decoder(dec, n=candidates, seed=seed), budget=budget, seed=seed,
                       progress=False)
    return res.belief


def planning_runs(belief, theta: np.ndarray, seed: int, args: argparse.Namespace, pool: DaskPool) -> dict:
    """reached, flops, final distance of the three planners on one problem."""
    robot0 = SimulatedRobot(theta)
    angle = np.random.default_rng(seed + 7).uniform(0, 2 * np.pi)
    goal = robot0.centre + args.distance * np.array([np.cos(angle), np.sin(angle)])
    out = {}
    for name, level in zip(planner_names(args.levels, not args.robust_only),
                           list(args.levels) + [1.0] * len(POINT_PLANNERS)):
        b = {"nominal": PointBelief(belief.space.nominal), "MAP": PointBelief(belief.map)}.get(name, belief)
        robust = name not in POINT_PLANNERS
        run = plan_to_goal(b, SimulatedRobot(theta), goal, radius=args.radius, max_steps=args.steps, level=level,
                           risk=args.risk, samples=args.samples, seed=seed, horizon=args.horizon,
                           learn=robust and args.learn, pool=pool, progress=False)
        out[name] = (bool(run.reached), len(run.steps), float(run.final_distance))
        if args.verbose:
            print(f"  {name}: " + "; ".join(f"{st.choice.action.label} score {st.choice.scores[st.choice.index]:+.2f} "
                                            f"-> {st.distance:.2f} m" for st in run.steps), flush=True)
    return out


def held_out_errors(theta: np.ndarray, cells: np.ndarray, belief, seed: int) -> np.ndarray:
    """One-step squared error E_i of every probed cell on a held-out flop at θ* (heading 2.0, change 0.3, 3 cables)."""
    data = simulate(theta, controller=FlopController(2.0, change=0.3, n_cables=3), duration=1.5, noise=1e-3,
                    seed=seed + 99)
    with TrajectoryObjective(data, loss="squared", n_workers=0) as E:
        return E.evaluate_batch(belief.theta[cells], parallel=False).errors


def _reach(values: list[float], threshold: float, n: int) -> int:
    """First experiment count k (0..n) with values[k] <= threshold, else n + 1."""
    hits = [k for k, v in enumerate(values) if v <= threshold]
    return hits[0] if hits else n + 1


def probing_runs(belief, theta: np.ndarray, seed: int, args: argparse.Namespace, pool: DaskPool) -> dict:
    """(experiments to the entropy target, experiments to the held-out target) per strategy."""
    settings = {"active": {"choose": "gain"}, "random": {"choose": "random"},
                "default flop": {"choose": "gain", "actions": [DEFAULT_FLOP]}}
    out, E = {}, None
    for name, kw in settings.items():
        run = probe(belief, SimulatedRobot(theta, noise=1e-3, seed=seed), steps=args.probes, cells=args.cells,
                    seed=seed, min_gain=-1.0, pool=pool, progress=False, **kw)
        if E is None:
            E = held_out_errors(theta, run.cells, belief, seed)
        ws = [run.initial_weights] + [s.weights for s in run.steps]
        ent = [float(-(w[w > 0] * np.log(w[w > 0])).sum()) for w in ws]
        held = [float(w @ np.nan_to_num(E, nan=np.nanmax(E))) / np.nanmin(E) for w in ws]
        out[name] = (_reach(ent, args.entropy, args.probes), _reach(held, 1 + args.tolerance, args.probes),
                     ent[-1], held[-1])
    return out


def _print_tables(plans: list[dict], probes: list[dict], args: argparse.Namespace) -> None:
    if "plan" in args.parts:
        _print_plans(plans, args)
    if "probe" in args.parts:
        _print_probes(probes, args)


def _print_plans(plans: list[dict], args: argparse.Namespace) -> None:
    n = len(plans)
    print(f"\nPlanning to a goal {args.distance:g} m away (radius {args.radius:g} m, at most {args.steps} flops, "
          f"K = {args.samples} draws, risk measure {args.risk}, "
          f"learning {'on' if args.learn else 'off'}, horizon {args.horizon}), "
          f"{n} seeds")
    print(f"{'planner':<16}{'reached':>10}{'rate':>7}{'mean flops':>12}{'mean final distance [m]':>26}")
    for name in planner_names(args.levels, not args.robust_only):
        r = [p[name] for p in plans]
        print(f"{name:<16}{sum(x[0] for x in r):>7}/{n:<2}{np.mean([x[0] for x in r]):>7.2f}"
              f"{np.mean([x[1] for x in r]):>12.2f}{np.mean([x[2] for x in r]):>26.2f}")


def _print_probes(probes: list[dict], args: argparse.Namespace) -> None:
    n = len(probes)
    print(f"\nProbing: M = {args.cells} cells drawn from P, at most {args.probes} experiments; targets: entropy <= "
          f"{args.entropy:g} nats, held-out error <= {1 + args.tolerance:g} x the best cell's ({args.probes + 1} = "
          f"not reached)")
    print(f"{'strategy':<14}{'to entropy (mean, reached)':>28}{'to held-out (mean, reached)':>30}"
          f"{'final entropy':>15}{'final held-out':>16}")
    for name in ("active", "random", "default flop"):
        r = [p[name] for p in probes]
        print(f"{name:<14}{np.mean([x[0] for x in r]):>20.2f}  {sum(x[0] <= args.probes for x in r):>2}/{n:<3}"
              f"{np.mean([x[1] for x in r]):>22.2f}  {sum(x[1] <= args.probes for x in r):>2}/{n:<3}"
              f"{np.mean([x[2] for x in r]):>15.2f}{np.mean([x[3] for x in r]):>16.3f}")


def _settings_key(args: argparse.Namespace) -> dict:
    """The settings a journal row depends on (rows made with others are not reused)."""
    names = ("distance", "radius", "steps", "samples", "levels", "robust_only", "risk", "horizon", "learn",
             "cells", "probes", "entropy", "tolerance", "candidates", "budget")
    return {n: getattr(args, n) for n in names}


def _journal(path: str | None, args: argparse.Namespace) -> dict[int, dict]:
    """{seed: row} of the rows in ``path`` made with these settings and these parts."""
    if path is None or not Path(path).exists():
        return {}
    rows = [json.loads(line) for line in Path(path).read_text().splitlines() if line.strip()]
    key = _settings_key(args)
    return {r["seed"]: r for r in rows if r["settings"] == key and set(args.parts) <= set(r["parts"])}


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, default=4)
    p.add_argument("--quick", action="store_true", help="1 seed, tiny sizes (smoke run)")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--distance", type=float, default=2.0)
    p.add_argument("--radius", type=float, default=0.5)
    p.add_argument("--steps", type=int, default=6)
    p.add_argument("--samples", type=int, default=8)
    p.add_argument("--levels", type=float, nargs="+", default=[0.5],
                   help="CVaR levels α: one robust planner per level (the nominal and MAP plans do not depend on it)")
    p.add_argument("--robust-only", action="store_true", help="skip the nominal and MAP plans")
    p.add_argument("--risk", choices=["cvar", "expected", "success"], default="cvar")
    p.add_argument("--horizon", type=int, choices=[1, 2], default=2, help="1: progress; 2: flops to go (lookahead)")
    p.add_argument("--no-learn", dest="learn", action="store_false",
                   help="the robust plan keeps P as loaded (default: re-weighs P by each executed flop)")
    p.add_argument("--cells", type=int, default=12)
    p.add_argument("--probes", type=int, default=4)
    p.add_argument("--entropy", type=float, default=0.5)
    p.add_argument("--tolerance", type=float, default=0.1)
    p.add_argument("--candidates", type=int, default=1024)
    p.add_argument("--budget", type=int, default=20)
    p.add_argument("--verbose", action="store_true", help="print every flop of every plan")
    p.add_argument("--parts", nargs="+", choices=["plan", "probe"], default=["plan", "probe"],
                   help="which tables to compute (default both)")
    p.add_argument("--out", default=None, help="journal (JSON lines, one row per seed): a rerun with the same "
                                               "settings skips the seeds it holds and prints the table of all")
    args = p.parse_args(argv)
    if args.quick:
        args.seeds, args.steps, args.samples, args.cells, args.probes = 1, 2, 2, 4, 1
        args.candidates, args.budget, args.distance = 256, 8, 1.0
    return args


def main(argv: list[str] | None = None) -> int:
    args = _arguments(argv)
    space, done = ParameterSpace.t6(), _journal(args.out, args)
    t0 = time.perf_counter()
    with DaskPool(n_workers=args.workers, warm_up=warm_up) as pool:
        for s in (s for s in range(args.seeds) if s not in done):
            theta = space.sample(1, seed=1000 + s)[0]
            belief = make_belief(theta, s, candidates=args.candidates, budget=args.budget)
            row = {"seed": s, "settings": _settings_key(args), "parts": list(args.parts),
                   "plans": planning_runs(belief, theta, s, args, pool) if "plan" in args.parts else {},
                   "probes": probing_runs(belief, theta, s, args, pool) if "probe" in args.parts else {}}
            done[s] = row
            if args.out:
                with open(args.out, "a") as fh:
                    fh.write(json.dumps(row) + "\n")
            print(f"seed {s}: plans {row['plans']}\n        probes {row['probes']}  "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    rows = [done[s] for s in range(args.seeds)]
    _print_tables([r["plans"] for r in rows], [r["probes"] for r in rows], args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
