"""How far criticism's joint refinement of one effect gets, round by round, on a testbed data set.

Criticism (criticism.search) screens an effect with the model's parameters held, then refines
(θ, η) together by bounded least squares (``CriticismConfig.local``: runs of at most 12 trial
points, repeated inside criticism up to ``LeastSquaresConfig.rounds`` times). This script makes one
run at a time, ``--rounds`` times, each from where the last one stopped, and prints, after each, the
effect's size and the fit and held-out errors E_F, E_H, so one sees how many runs the fit needs.
Per data set and seed (flops version 2, 0.2 mm noise; fit on ``flop_0`` and ``flop_1``, held out
``heldout_0``, as diagnose splits them):

1. the mismatch stage (criticism.mismatch, journalled under ``--journals``) augments the T6 and
   the base is the augmented model re-tuned on the fit flops (criticism.polish), as in
   benchmarks/effects_oracle.py;
2. the effect is screened (criticism.screening.fit_effect, θ held), then refined jointly
   ``--rounds`` times; with ``--start V`` the effect's (single) parameter is set to V after the
   screening and the joint refinement starts there, so two starts can be compared: a fit that
   ends lower from another start was stuck where criticism's start left it.

    .venv/bin/python benchmarks/joint_rounds.py --dataset drag --seed 0 --effect viscous_drag --rounds 3
    .venv/bin/python benchmarks/joint_rounds.py --dataset actuator_delay --seed 6 --effect actuator_delay --start 0.05
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from effects_oracle import staged

from belief.least_squares import LeastSquaresConfig
from criticism import CriticismConfig
from criticism.screening import effect_start, fit_effect
from criticism.search import polish
from physics.effects import EFFECT_TYPES


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default="drag")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--effect", default="viscous_drag", choices=sorted(EFFECT_TYPES))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--journals", default=".cache/oracle", help="the stage's journal folder per data set and seed "
                    "(benchmarks/effects_oracle.py writes the same)")
    ap.add_argument("--start", type=float, help="the effect's size the joint refinement starts from "
                    "(default: the screened one); effects with one parameter only")
    args = ap.parse_args(argv)
    config, start = CriticismConfig(local=LeastSquaresConfig(rounds=1)), time.perf_counter()
    s = staged(args.dataset, args.seed, Path(args.journals), config)
    try:
        print(f"base: E_F {s.base.parts[s.fit].sum():.4f}, E_H {s.base.parts[s.held].sum():.4f}", flush=True)
        extended, theta, indices = effect_start(s.model, s.base.theta, EFFECT_TYPES[args.effect]())
        theta, parts = fit_effect(extended, theta, indices, s.fit, grid=config.grid, refine=config.refine)
        _report("screened", extended.space.names, theta, indices, parts, s.fit, s.held, start)
        if args.start is not None:
            if len(indices) != 1:
                raise SystemExit(f"--start needs an effect with one parameter; {args.effect} has {len(indices)}.")
            theta[indices[0]] = args.start
            _report("start", extended.space.names, theta, indices, extended.evaluate_parts(theta), s.fit, s.held,
                    start)
        for k in range(args.rounds):
            joint = polish(extended, theta, s.fit, config)
            theta = joint.theta
            _report(f"joint round {k + 1}", extended.space.names, theta, indices, joint.parts, s.fit, s.held, start)
    finally:
        s.full.close()
    return 0


def _report(label, names, theta, indices, parts, fit, held, start) -> None:
    sizes = ", ".join(f"{names[j]}={theta[j]:.4g}" for j in indices)
    print(f"{label}: {sizes}; E_F {parts[fit].sum():.4f}, E_H {parts[held].sum():.4f} "
          f"({time.perf_counter() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    sys.exit(main())
