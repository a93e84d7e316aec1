"""Tutorial: plan flops on a belief, then probe to sharpen it.

1. A belief: a short identification of a robot with hidden parameters θ* from one 1.5 s flop.
2. A robust plan: flop that robot (simulated at θ*) to a goal 2 m away, choosing each flop by the
   CVaR of minus the flops still to go under draws of the belief, replanning after each flop; the
   nominal plan (all mass on the nominal θ) for comparison. Figure: ``plan.png``.
3. Probing: choose flops with the largest expected information gain on cells drawn from the
   belief, run them on the robot, update P. Figure: ``probe.png``.

Run::

    .venv/bin/python docs/tutorial_plan.py --out out/tutorial_plan        # about 5 min on 2 cores
    .venv/bin/python docs/tutorial_plan.py --quick --out /tmp/tut         # what the test suite runs

(``TENSEGRID_QUICK=1`` also selects the quick mode.)
"""
from __future__ import annotations

import argparse
import os

import numpy as np

from belief import SobolCandidates, identify
from embeddings import Identity
from physics import FlopController, ParameterSpace, TrajectoryObjective, simulate
from planners import PointBelief, SimulatedRobot, plan_to_goal, probe
from planners.plots import plot_plan, plot_probe


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="tiny sizes (test suite)")
    parser.add_argument("--out", default="out/tutorial_plan")
    args = parser.parse_args(argv)
    quick = args.quick or os.environ.get("TENSEGRID_QUICK") == "1"
    os.makedirs(args.out, exist_ok=True)

    # 1. The robot we have: θ* drawn inside the ±10 % box, hidden from the planner. One recorded
    #    flop (1 mm motion-capture noise) and a short identification give the belief P.
    space = ParameterSpace.t6()
    truth = space.sample(1, seed=1001)[0]
    data = simulate(truth, controller=FlopController(0.0), duration=1.5, noise=1e-3, seed=0)
    with TrajectoryObjective(data, loss="squared", n_workers=0) as E:
        decoder = Identity(space)
        cells = SobolCandidates.for_decoder(decoder, n=256 if quick else 1024, seed=0)
        belief = identify(E, decoder, cells, budget=6 if quick else 20, seed=0, progress=False).belief
    print(f"belief: {belief.n_cells} cells, entropy {belief.entropy():.2f} nats")

    # 2. Plan to a goal 2 m away: each step draws K θ from P, simulates every candidate flop from
    #    the sensed state, and picks the best CVaR (α = 0.5) of minus the flops still to go.
    small = {"changes": (0.3,), "n_cables": (4,)} if quick else None
    goal = SimulatedRobot(truth).centre + np.array([2.0, 0.0])
    steps = 1 if quick else 6
    run = plan_to_goal(belief, SimulatedRobot(truth), goal, radius=0.5, max_steps=steps, level=0.5,
                       samples=2 if quick else 8, seed=0, actions_kw=small, progress=False)
    nominal = plan_to_goal(PointBelief(space.nominal), SimulatedRobot(truth), goal, radius=0.5, max_steps=steps,
                           seed=0, actions_kw=small, progress=False)
    for name, r in (("robust", run), ("nominal", nominal)):
        print(f"{name:>8} plan: {'reached' if r.reached else 'not reached'} after {len(r.steps)} flops, "
              f"final distance {r.final_distance:.2f} m")
    plot_plan(run, os.path.join(args.out, "plan.png"), others={"nominal": nominal})

    # 3. Probe: 12 cells drawn from P are the hypotheses; each probe is the flop whose predicted
    #    trajectories under those cells differ most (expected information gain), then P is
    #    re-weighted by how well each cell predicted what the robot did.
    pr = probe(belief, SimulatedRobot(truth, noise=1e-3, seed=0), steps=1 if quick else 3,
               cells=3 if quick else 12, seed=0, actions_kw=small, progress=False)
    for k, s in enumerate(pr.steps, start=1):
        print(f"probe {k}: {s.action.label}, expected gain {s.gain:.2f} nats, entropy {s.entropy_before:.2f} -> "
              f"{s.entropy_after:.2f} nats")
    print(pr.belief.summary(truth=truth))
    plot_probe(pr, os.path.join(args.out, "probe.png"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
