"""How much of the foreign robot's drift is its rolling friction, and how much of that a
rolling-resistance torque in DART recovers.

The testbed's caps have rolling friction 0.01 and its ground 1.0; Bullet combines them with the
lateral friction into 0.51 m for a cap on the ground (benchmarks/testbed/robot.py). For nominal
testbed robot ``--seed`` (noise-free, flops version 1) this script writes the robot's flops twice,
as made and with the ground's rolling friction 0 (``ground_rolling``; the cap's 0.01 × 1.0
stays), and prints, at 0.2, 0.3, 0.4, 0.5, 1 and 3 s after the first sample, the mean node
distance [mm] between

- the testbed as made and its own first sample (how far it has moved, the flop's commands start
  at 0.2 s);
- the testbed as made and the testbed without the ground's rolling friction;
- DART at the testbed's true θ with the mismatch stage's laws at their true sizes (the
  tension-limited actuator, 6 cm cable anchors) and each of the two;
- the same DART model with physics.effects.RollingResistance at each ``--levers`` μ_r [m] and the
  testbed as made;
- the testbed's own anchor and contact laws in DART (physics.effects.FixedCableAnchors, anchors
  fixed to the rods, and physics.effects.CylinderCaps, its flat-ended cylinders as contact shapes)
  against the testbed without rolling friction, and with rolling resistance at each ``--levers``
  against the testbed as made.

    .venv/bin/python benchmarks/rolling_ablation.py --seed 2
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from drift_probes import TIMES, at_times  # benchmarks/ (the script's folder)

from physics import TrajectoryObjective, load_trajectory
from physics.effects import (
    CableAnchors,
    CylinderCaps,
    FixedCableAnchors,
    RollingResistance,
    TensionLimitedActuation,
    model_space,
)

LABELS = ("flop_0", "flop_1", "flop_2", "heldout_0")
OFFSET = 0.06


def testbed_files(seed: int, ground_rolling: float) -> Path:
    """Folder of nominal robot ``seed``'s noise-free flops with the ground's rolling friction given."""
    from testbed.datasets import make_dataset
    from testbed.record import Observation
    folder = Path(".cache") / "testbed" / f"nominal-s{seed}-n0-rolling{ground_rolling:g}"
    if not all((folder / f"{label}.nc").exists() for label in LABELS):
        make_dataset("nominal", seed, folder, obs=Observation(noise=0.0), ground_rolling=ground_rolling)
    return folder


def dart_rollout(path: Path, lever: float, testbed_laws: bool = False) -> np.ndarray:
    """Nodes (T x 12 x 3) [m] of DART's open-loop rollout of the flop in ``path`` at the testbed's θ
    (re-aimed anchors and spheres, or with ``testbed_laws`` fixed anchors and cylinder caps)."""
    anchors = FixedCableAnchors() if testbed_laws else CableAnchors()
    effects = [TensionLimitedActuation(), anchors, *([CylinderCaps()] if testbed_laws else []), RollingResistance()]
    space = model_space(effects)
    theta = space.as_array({**space.as_dict(None), anchors.parameters()[0].name: OFFSET, "rolling_resistance": lever},
                           check_bounds=False)
    with TrajectoryObjective([load_trajectory(path)], horizon="rollout", loss="squared", effects=effects,
                             n_workers=0) as objective:
        return np.asarray(objective.predictions(theta)[0].values, float)


def apart(a: np.ndarray, b: np.ndarray, time: np.ndarray) -> str:
    """Mean node distance between node arrays a and b (T x 12 x 3) at TIMES after the first sample, in mm."""
    return at_times(np.linalg.norm(a - b, axis=-1).mean(axis=1), time)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--levers", type=float, nargs="+", default=[0.1, 0.2, 0.5, 1.0])
    args = ap.parse_args(argv)
    made, ablated = testbed_files(args.seed, 1.0), testbed_files(args.seed, 0.0)
    print(f"mean node distance [mm] at {', '.join(f'{t:g}' for t in TIMES)} s; nominal testbed robot {args.seed}")
    for label in LABELS:
        ds = load_trajectory(made / f"{label}.nc")
        time, observed = np.asarray(ds["time"].values, float), np.asarray(ds["nodes"].values, float)
        without = np.asarray(load_trajectory(ablated / f"{label}.nc")["nodes"].values, float)
        dart = dart_rollout(made / f"{label}.nc", 0.0)
        rows = {"testbed vs its first sample": apart(observed, observed[:1], time),
                "testbed vs testbed without": apart(observed, without, time),
                "DART vs testbed": apart(dart, observed, time),
                "DART vs testbed without": apart(dart_rollout(ablated / f"{label}.nc", 0.0), without, time)}
        rows.update({f"DART + rolling {mu:g} m vs testbed": apart(dart_rollout(made / f"{label}.nc", mu),
                                                                observed, time) for mu in args.levers})
        rows["DART fixed, cylinders vs without"] = apart(dart_rollout(ablated / f"{label}.nc", 0.0, True), without,
                                                         time)
        rows.update({f"DART fixed, cyl., rolling {mu:g} m vs testbed": apart(
            dart_rollout(made / f"{label}.nc", mu, True), observed, time) for mu in args.levers})
        for name, text in rows.items():
            print(f"{label:10s} {name:44s} {text}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
