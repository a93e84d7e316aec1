"""How many distinct flops a testbed data set has across seeds: flops whose command sequences are
equal (to 1e-9 m) are one experiment, whatever seed or label they carry.

The testbed's flop controller tips the robot over one of the three edges of the face it rests on,
the edge whose outward normal is closest to the flop's heading (benchmarks/testbed/controller.py).
On a robot that does not change with the seed (``nominal``, and the effect data sets whose
effect has a fixed size), three headings 120° apart then pick the same three edges for every
seed, in another order, and the seeds differ only in their noise and in which flop is held out.

    .venv/bin/python benchmarks/testbed_flops.py                      # nominal, seeds 0-4
    .venv/bin/python benchmarks/testbed_flops.py --dataset drag --seeds 2
    .venv/bin/python benchmarks/testbed_flops.py --flops-version 2 --seeds 3   # actuation drawn per seed
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from physics import load_trajectory

LABELS = ("flop_0", "flop_1", "flop_2", "heldout_0")


def groups(commands: dict[tuple[int, str], np.ndarray]) -> list[list[tuple[int, str]]]:
    """The (seed, label) keys of ``commands`` (each T x 24 [m]) grouped by equal command sequences."""
    out: list[list[tuple[int, str]]] = []
    for key, c in commands.items():
        for group in out:
            first = commands[group[0]]
            if first.shape == c.shape and np.allclose(first, c, atol=1e-9):
                group.append(key)
                break
        else:
            out.append([key])
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default="nominal")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--noise", type=float, default=0.0002)
    ap.add_argument("--flops-version", type=int, default=1, help="of the testbed's flops (testbed.datasets)")
    args = ap.parse_args(argv)
    from testbed.datasets import cached_dataset
    commands = {}
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        files = cached_dataset(args.dataset, seed, noise=args.noise, version=args.flops_version)
        for label in LABELS:
            commands[(seed, label)] = np.asarray(load_trajectory(files[label])["controls"].values, float)
    found = groups(commands)
    print(f"{args.dataset} (flops version {args.flops_version}): {len(commands)} flops, "
          f"{len(found)} distinct command sequences")
    for group in found:
        print("  " + ", ".join(f"seed {s} {label}" for s, label in group))
    return 0


if __name__ == "__main__":
    sys.exit(main())
