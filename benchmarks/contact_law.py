"""The end caps' contact law and the observations' offset, read from the flops (physics.contact_law).

For testbed data sets (Bullet: flat cylinder ends; flops of version 2, 0.2 mm noise) and for
scenarios of the project's own engine (DART: spheres at the nodes; benchmarks/effects.py,
1.5-s flops), each over ``--seeds`` seeds, the reading of all three flops of a data set: the shape
chosen, the offset b [mm] and its standard error under the flat law, the flat law's radius, both
RMS residuals [mm], and the truth (the testbed's marker offset along the floor normal; the own
engine's sensor bias). Then per source the shapes chosen and, for the testbed, the largest
|b − b*| over the data sets with and without a marker offset.

    .venv/bin/python benchmarks/contact_law.py --seeds 3
    .venv/bin/python benchmarks/contact_law.py --seeds 2 --first-seed 3 --testbed marker_offset nominal --own

``--testbed`` or ``--own`` with no names skips that source.
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np
from tqdm import tqdm

from physics.contact_law import ContactLaw, contact_law

TESTBED = ("nominal", "marker_offset", "slope", "drag", "actuator_delay", "hysteresis", "extra_mass",
           "ground_viscosity", "slope+delay")
OWN = ("none", "sensor_bias", "ground_slope", "end_cap_radius")


def testbed_reading(name: str, seed: int) -> tuple[ContactLaw | None, float]:
    """The reading of a testbed data set and its true offset along z [m] (the floor is level or the
    offset is zero in every data set)."""
    from effects import testbed_data
    data, _, truth = testbed_data(name, seed, 2)
    return contact_law(data), float(np.asarray(truth.get("marker_offset", (0.0, 0.0, 0.0)), float)[2])


def own_reading(name: str, seed: int) -> tuple[ContactLaw | None, float]:
    """The reading of an own-engine scenario and its true sensor bias [m]."""
    from effects import make_data
    data, truth = make_data(name, seed)
    return contact_law(data), float(truth.get("sensor_bias_z", 0.0))


def line(source: str, name: str, seed: int, law: ContactLaw | None, truth: float) -> str:
    """One printed row: the reading (lengths in mm) next to the true offset."""
    if law is None:
        return f"{source:8s} {name:18s} {seed:4d}  no contact samples"
    b = "      -" if law.offset is None else f"{1e3 * law.offset:+7.1f}"
    return (f"{source:8s} {name:18s} {seed:4d}  {law.shape:9s} {b} {1e3 * law.offset_se:5.1f} {1e3 * truth:+6.1f} "
            f"{1e3 * law.radius:7.1f} {1e3 * law.rms_flat:8.2f} {1e3 * law.rms_sphere:8.2f} {law.samples:6d}")


def summary(rows: list[tuple[str, str, int, ContactLaw | None, float]]) -> None:
    """Per source: the shapes chosen, and |b − b*| over the data sets with and without an offset."""
    for source in sorted({r[0] for r in rows}):
        mine = [r for r in rows if r[0] == source]
        shapes = {s: sum(1 for r in mine if r[3] is not None and r[3].shape == s) for s in ("flat", "sphere", "undecided")}
        print(f"{source}: {len(mine)} data sets; shapes " + ", ".join(f"{k} {v}" for k, v in shapes.items()))
        for offset in (True, False):
            errors = [abs(r[3].offset - r[4]) for r in mine if r[3] is not None and r[3].offset is not None
                      and (r[4] != 0.0) == offset]
            if errors:
                print(f"  {'with' if offset else 'without'} an offset: |b - b*| median {1e3 * np.median(errors):.1f} mm, "
                      f"largest {1e3 * max(errors):.1f} mm over {len(errors)}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--testbed", nargs="*", default=list(TESTBED), help="testbed data sets (none: skip)")
    ap.add_argument("--own", nargs="*", default=list(OWN), help="own-engine scenarios (none: skip)")
    ap.add_argument("--out", default=None, help="also append the readings here (JSON lines)")
    args = ap.parse_args(argv)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    jobs = [("testbed", n, s) for n in args.testbed for s in seeds]
    jobs += [("own", n, s) for n in args.own for s in seeds]
    print(f"{'source':8s} {'data set':18s} {'seed':>4s}  {'shape':9s} {'b [mm]':>7s} {'se':>5s} {'b*':>6s} "
          f"{'r flat':>7s} {'RMS flat':>8s} {'RMS sph':>8s} {'n':>6s}")
    rows = []
    for source, name, seed in tqdm(jobs, desc="readings", leave=False):
        law, truth = (testbed_reading if source == "testbed" else own_reading)(name, seed)
        rows.append((source, name, seed, law, truth))
        tqdm.write(line(source, name, seed, law, truth))
        if args.out:
            with open(args.out, "a") as f:
                f.write(json.dumps({"source": source, "dataset": name, "seed": seed, "truth": truth,
                                    "reading": None if law is None else vars(law)}) + "\n")
    summary(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
