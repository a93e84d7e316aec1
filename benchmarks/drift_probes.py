"""Where the open-loop drift on the foreign robot comes from: DART at the testbed's true θ with
the mismatch stage's components at their true sizes, one law changed at a time.

For nominal testbed robot ``--seed`` (benchmarks/testbed, 0.2 mm noise), each flop (``flop_0``,
``flop_1``, ``heldout_0``) is rolled out open loop from its first sample (its recorded commands,
physics.TrajectoryObjective with horizon "rollout") by DART with the tension-limited actuator
(the testbed's law) and 6 cm anchors (the testbed's offset):

- ``re-aimed``: physics.effects.CableAnchors (anchors aimed at the cable's other end every step);
- ``fixed``: physics.effects.FixedCableAnchors (anchors fixed to the rods, as in the testbed);
- ``fixed, friction μ``: the same with the ground friction μ (ModelOptions.friction; the testbed's
  is 0.5 and so is DART's default).

Printed: the drift [mm] (mean node distance to the data) at 0.2, 0.3, 0.4, 0.5, 1 and 3 s, and
the distance between the fixed and re-aimed rollouts themselves.

    .venv/bin/python benchmarks/drift_probes.py --seed 2
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from physics import ModelOptions, TrajectoryObjective, load_trajectory
from physics.effects import CableAnchors, Effect, FixedCableAnchors, TensionLimitedActuation, model_space

LABELS = ("flop_0", "flop_1", "heldout_0")
TIMES = (0.2, 0.3, 0.4, 0.5, 1.0, 3.0)
OFFSET = 0.06


def rollout(ds, anchors: Effect, friction: float) -> np.ndarray:
    """Nodes (T x 12 x 3) [m] of DART's open-loop rollout of flop ``ds`` at the testbed's θ."""
    effects = [TensionLimitedActuation(), anchors]
    theta = model_space(effects).nominal.copy()
    theta[-1] = OFFSET
    with TrajectoryObjective([ds], horizon="rollout", loss="squared", effects=effects, n_workers=0,
                             options=ModelOptions(friction=friction)) as objective:
        return np.asarray(objective.predictions(theta)[0].values, float)


def at_times(distance: np.ndarray, time: np.ndarray) -> str:
    """``distance`` (T,) [m] at TIMES after the first sample, in mm."""
    rows = [int(np.argmin(np.abs(time - time[0] - t))) for t in TIMES if t <= time[-1] - time[0] + 1e-9]
    return "  ".join(f"{1e3 * distance[i]:6.1f}" for i in rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--frictions", type=float, nargs="+", default=[0.3, 0.8])
    args = ap.parse_args(argv)
    from testbed.datasets import cached_dataset
    files = cached_dataset("nominal", args.seed, noise=0.0002)
    print(f"drift [mm] at {', '.join(f'{t:g}' for t in TIMES)} s; nominal testbed robot {args.seed}")
    for label in LABELS:
        ds = load_trajectory(files[label])
        observed, time = np.asarray(ds["nodes"].values, float), np.asarray(ds["time"].values, float)
        runs = {"re-aimed": rollout(ds, CableAnchors(), 0.5), "fixed": rollout(ds, FixedCableAnchors(), 0.5)}
        runs.update({f"fixed, friction {mu:g}": rollout(ds, FixedCableAnchors(), mu) for mu in args.frictions})
        for name, nodes in runs.items():
            print(f"{label:10s} {name:22s} {at_times(np.linalg.norm(nodes - observed, axis=-1).mean(axis=1), time)}")
        apart = np.linalg.norm(runs["fixed"] - runs["re-aimed"], axis=-1).mean(axis=1)
        print(f"{label:10s} {'fixed vs re-aimed':22s} {at_times(apart, time)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
