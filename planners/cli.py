"""``tensegrid plan`` and ``tensegrid probe``: the command-line layer over :mod:`planners`.

::

    tensegrid plan BELIEF.nc --goal X Y [--level A] [--samples K] [--risk cvar] [--horizon 2]
                   [--no-learn] [--truth T] [--compare] --out DIR
    tensegrid probe BELIEF.nc [--truth T] [--steps N] [--cells M] [--sigma S] [--targets NAME ...]
                    [--next DIR/next_recording.json] --out DIR

The robot is simulated at the truth T: ``nominal`` (default), a JSON file ({name: value} or 15
numbers in the order of the T6 space) or a trajectory file (netCDF) that carries the θ it was
simulated at. ``plan`` flops the robot to the goal, replanning after each flop under the belief
(re-weighed by the flops so far; ``--no-learn`` keeps P as loaded; with ``--compare`` also under
the nominal θ and the MAP θ) and writes ``plan.json`` and ``plan.png``; ``probe`` runs active
identification and writes ``probe.json``, ``probe.png`` and ``belief_probed.nc``; with ``--next`` it
runs the motion ``tensegrid identify`` suggested recording next (belief.next_recording).
"""
from __future__ import annotations

import argparse
import json
import os
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from belief.belief import Belief
    from belief.sampling import SamplingBelief
    from planners.actions import FlopAction
    from planners.robust import PlanStep

__all__ = ["register_plan", "register_probe", "read_truth", "read_next"]


def read_truth(value: str) -> np.ndarray:
    """θ* (15 values) from "nominal", a JSON file or a trajectory netCDF with a ``theta`` variable."""
    from physics.parameters import ParameterSpace
    from planners.errors import PlannerError

    space = ParameterSpace.t6()
    if value == "nominal":
        return space.nominal.copy()
    if not os.path.exists(value):
        raise PlannerError(f"--truth must be 'nominal', a JSON file or a trajectory .nc file, got {value!r} (no such "
                           "file).")
    if value.endswith(".json"):
        with open(value) as fh:
            data = json.load(fh)
        return space.as_array(data if isinstance(data, dict) else np.asarray(data, dtype=float), check_bounds=False)
    from physics.trajectory import load_trajectory

    ds = load_trajectory(value)
    if "theta" not in ds:
        raise PlannerError(f"{value} carries no 'theta' variable; give the truth as a JSON file instead.")
    return np.asarray(ds["theta"].sel(parameter=list(space.names)).values, dtype=float)


def _load_belief(path: str, group: str | None) -> Belief:
    """The Belief in ``path`` (root, or ``group``; a result.nc of ``tensegrid identify`` holds it in "belief")."""
    from belief.belief import Belief
    from belief.errors import BeliefError

    try:
        return Belief.load(path, group=group)
    except BeliefError:
        if group is not None:
            raise
        return Belief.load(path, group="belief")


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("belief", help="a belief file (Belief.save; tensegrid identify writes one inside result.nc)")
    p.add_argument("--group", default=None,
                   help="netCDF group holding the belief (default: the root, else 'belief' as in result.nc)")
    p.add_argument("--truth", default="nominal", help="θ* of the simulated robot: nominal, FILE.json or DATA.nc")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=0, help="dask worker processes for the rollouts (0 = serial)")
    p.add_argument("--out", required=True, help="output directory")


def register_plan(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``tensegrid plan``."""
    p = subparsers.add_parser("plan", help="flop to a goal, replanning under the belief (robust plan)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(p)
    p.add_argument("--goal", nargs=2, type=float, required=True, metavar=("X", "Y"), help="goal point [m]")
    p.add_argument("--risk", choices=["cvar", "expected", "success"], default="cvar",
                   help="risk measure of a flop's outcomes over the draws of P (default cvar)")
    p.add_argument("--level", type=float, default=0.5, help="CVaR level α in (0, 1] (default 0.5)")
    p.add_argument("--samples", type=int, default=12, help="θ draws of the belief per candidate (default 12)")
    p.add_argument("--radius", type=float, default=0.5, help="goal radius [m] (default 0.5)")
    p.add_argument("--horizon", type=int, choices=[1, 2], default=2,
                   help="1: progress of each flop; 2: flops to go, the next flop predicted (default 2)")
    p.add_argument("--steps", type=int, default=8, help="at most this many flops (default 8)")
    p.add_argument("--no-learn", dest="learn", action="store_false",
                   help="keep P as loaded (default: re-weigh P by each executed flop)")
    p.add_argument("--compare", action="store_true", help="also plan with the nominal θ and the MAP θ")
    p.set_defaults(func=run_plan)


def register_probe(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``tensegrid probe``."""
    p = subparsers.add_parser("probe", help="active identification: probe flops with the largest expected gain",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(p)
    p.add_argument("--steps", type=int, default=3, help="at most this many probes (default 3)")
    p.add_argument("--cells", type=int, default=12, help="cells drawn from P as hypotheses (default 12)")
    p.add_argument("--sigma", type=float, default=0.02, help="observation noise per coordinate [m] (default 0.02)")
    p.add_argument("--min-gain", type=float, default=0.05, help="stop when no probe is expected to gain more [nats]")
    p.add_argument("--targets", nargs="*", default=[], help="stop once these parameters are identified")
    p.add_argument("--next", default=None, metavar="FILE",
                   help="probe with the motion tensegrid identify suggested (its next_recording.json) as the only "
                        "candidate, instead of choosing among flops by expected gain")
    p.set_defaults(func=run_probe)


def _step_json(step: PlanStep) -> dict[str, Any]:
    return {"action": step.choice.action.as_dict(), "label": step.choice.action.label,
            "scores": step.choice.scores.tolist(), "candidates": [a.label for a in step.choice.rollouts.actions],
            "status": step.outcome.status, "face": list(step.outcome.face), "after": step.after.tolist(),
            "distance": step.distance, "entropy": step.entropy}


def run_plan(args: argparse.Namespace) -> int:
    """Run ``tensegrid plan`` (module docstring)."""
    from physics.outputs import check_output_dir, make_output_dir
    from physics.pool import DaskPool
    from planners.plots import plot_plan
    from planners.robust import PointBelief, plan_to_goal

    check_output_dir(args.out)          # a bad --out is an error before any work; the folder is made at the end
    belief = _load_belief(args.belief, args.group)
    truth = read_truth(args.truth)
    planners: dict[str, SamplingBelief] = {"robust": belief}
    if args.compare:
        planners.update({"nominal": PointBelief(belief.space.nominal), "MAP": PointBelief(belief.map)})
    runs, record = {}, {"goal": list(args.goal), "truth": truth.tolist(), "risk": args.risk,
                        "level": args.level, "samples": args.samples, "radius": args.radius,
                        "horizon": args.horizon, "learn": args.learn, "runs": {}}
    with DaskPool(n_workers=args.workers) as pool:
        for name, b in planners.items():
            run = plan_to_goal(b, truth, args.goal, radius=args.radius, max_steps=args.steps, risk=args.risk,
                               level=args.level, samples=args.samples, seed=args.seed, horizon=args.horizon,
                               learn=args.learn, pool=pool)
            runs[name] = run
            record["runs"][name] = {"reached": run.reached, "final_distance": run.final_distance,
                                    "steps": [_step_json(s) for s in run.steps]}
            print(f"{name:>8}: {'reached' if run.reached else 'not reached'} in {len(run.steps)} flops, final "
                  f"distance {run.final_distance:.2f} m; flops: {', '.join(s.choice.action.label for s in run.steps)}")
    make_output_dir(args.out)
    with open(os.path.join(args.out, "plan.json"), "w") as fh:
        json.dump(record, fh, indent=1)
    plot_plan(runs["robust"], os.path.join(args.out, "plan.png"),
              others={k: v for k, v in runs.items() if k != "robust"})
    print(f"wrote {os.path.join(args.out, 'plan.json')}\nwrote {os.path.join(args.out, 'plan.png')}")
    return 0


def read_next(path: str) -> FlopAction:
    """The motion of a ``next_recording.json`` (belief.cli_next) as a FlopAction; PlannerError when the
    file is missing or holds no motion."""
    from planners.actions import FlopAction
    from planners.errors import PlannerError

    try:
        with open(path) as fh:
            motion = json.load(fh)["motion"]
        return FlopAction(**{k: motion[k] for k in ("heading", "change", "n_cables", "start", "stop", "duration")})
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise PlannerError(f"--next {path}: not a next_recording.json of tensegrid identify ({exc}); give the file "
                           "identify wrote into its --out.") from None


def run_probe(args: argparse.Namespace) -> int:
    """Run ``tensegrid probe`` (module docstring)."""
    from physics.outputs import check_output_dir, make_output_dir
    from planners.plots import plot_probe
    from planners.probe import probe

    check_output_dir(args.out)
    actions = None if args.next is None else (read_next(args.next),)
    belief = _load_belief(args.belief, args.group)
    truth = read_truth(args.truth)
    run = probe(belief, truth, steps=args.steps, cells=args.cells, sigma=args.sigma, seed=args.seed,
                min_gain=args.min_gain, targets=args.targets, actions=actions, n_workers=args.workers)
    make_output_dir(args.out)
    for k, s in enumerate(run.steps, start=1):
        print(f"probe {k}: {s.action.label}  expected gain {s.gain:.3f} nats  entropy {s.entropy_before:.3f} -> "
              f"{s.entropy_after:.3f} nats  identified: {[n for n, v in s.verdicts.items() if v == 'identified']}")
    print(f"stopped: {run.stopped}")
    print(run.belief.summary(truth=truth))
    print(f"(P lives on the {len(run.cells)} probed cells: verdicts say which of those cells the probes kept, "
          "not how precisely θ is known between cells)")
    record = {"truth": truth.tolist(), "cells": run.cells.tolist(), "stopped": run.stopped,
              "steps": [{"action": s.action.as_dict(), "label": s.action.label, "gain": s.gain,
                         "gains": s.gains.tolist(), "entropy_before": s.entropy_before,
                         "entropy_after": s.entropy_after, "weights": s.weights.tolist(), "verdicts": s.verdicts,
                         "status": s.status} for s in run.steps]}
    with open(os.path.join(args.out, "probe.json"), "w") as fh:
        json.dump(record, fh, indent=1)
    run.belief.save(os.path.join(args.out, "belief_probed.nc"))
    plot_probe(run, os.path.join(args.out, "probe.png"))
    print(f"wrote {args.out}/probe.json, probe.png, belief_probed.nc")
    return 0
