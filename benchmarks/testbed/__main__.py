"""``python -m testbed`` (or ``tensegrid-testbed``): write named testbed data sets.

    tensegrid-testbed list
    tensegrid-testbed dataset perturbed --seed 3                 # -> .cache/testbed/perturbed-s3/
    tensegrid-testbed dataset slope --seed 0 --out DIR --noise 0.001 --missing 0.02
    tensegrid-testbed dataset nominal --engine mujoco                # the same robot in MuJoCo
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from testbed.datasets import DATASETS, ENGINES, FLOP_VERSIONS, make_dataset, robot_for
from testbed.record import Observation

__all__ = ["main", "default_folder"]


def default_folder(name: str, seed: int, engine: str = "bullet") -> Path:
    """Where a data set is cached unless told otherwise (ignored by git)."""
    return Path(".cache") / "testbed" / (f"{name}-s{seed}" + (f"-{engine}" if engine != "bullet" else ""))


def main(argv: "list[str] | None" = None) -> int:
    parser = argparse.ArgumentParser(prog="tensegrid-testbed", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the data sets and what their robots hide")
    make = sub.add_parser("dataset", help="write a named data set (3 flops and a held-out flop)")
    make.add_argument("name", choices=sorted(DATASETS))
    make.add_argument("--seed", type=int, default=0)
    make.add_argument("--out", type=Path, default=None, help="folder (default .cache/testbed/NAME-sSEED)")
    make.add_argument("--noise", type=float, default=1e-3, help="motion-capture noise [m] (default 0.001)")
    make.add_argument("--missing", type=float, default=0.0, help="fraction of samples lost (NaN)")
    make.add_argument("--duration", type=float, default=3.0, help="seconds per flop")
    make.add_argument("--flops-version", type=int, choices=FLOP_VERSIONS, default=1,
                      help="1: the same actuation for every seed; 2: actuation drawn from the seed")
    make.add_argument("--engine", choices=ENGINES, default="bullet",
                      help="bullet: the testbed (default); mujoco: the same robot in a third engine")
    args = parser.parse_args(argv)
    if args.command == "list":
        for name in sorted(DATASETS):
            robot, _ = robot_for(name, 0)
            print(f"{name:18s} {'θ* drawn ±10 %' if DATASETS[name][0] else 'nominal θ':15s} {robot.effects.active()}")
        return 0
    out = args.out or default_folder(args.name, args.seed, args.engine)
    paths = make_dataset(args.name, args.seed, out, duration=args.duration, engine=args.engine,
                         obs=Observation(noise=args.noise, missing=args.missing), version=args.flops_version)
    print("\n".join(str(p) for p in paths))
    return 0


if __name__ == "__main__":
    sys.exit(main())
