"""Tutorial: from your robot's motion-capture CSV to an identified model, a replay and a diagnosis.

The commands of docs/your-robot.md, run on CSVs this script writes as a motion-capture lab would
export them. The "robot" is the simulated SUPERball with parameters off nominal (TRUTH below); it
flops three times, toward headings 0, 2.1 and 4.2 rad, 1.5 s each from rest. Each flop becomes
one CSV:

- a column ``Time (s)`` on a 100 Hz clock, each timestamp off its tick by up to 0.3 ms, two whole
  frames left out;
- the markers ``A1:X, A1:Y, A1:Z, ..., F2:Z`` in millimetres with y up, 1 mm of noise: rod A joins
  A1 and A2, rod B joins B1 and B2, ... (nodes 0..11 of docs/data-format.md);
- one commanded rest length per cable in millimetres, named by the markers at its ends
  (``motor_A1_C1``, ...);
- and a ``Frame`` column, which convert ignores.

Then it runs the doc's commands (``commands()``) in the output folder, printing each before it
runs it. Run::

    .venv/bin/python docs/tutorial_your_robot.py --out out/your_robot            # default settings
    .venv/bin/python docs/tutorial_your_robot.py --quick --out /tmp/your_robot   # what the test runs

``--quick`` (or ``TENSEGRID_QUICK=1``) appends QUICK_IDENTIFY to identify's command and
QUICK_DIAGNOSE to diagnose's; nothing else differs.
"""
from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from physics import FlopController, ParameterSpace, simulate
from physics.geometry import CABLE_NODES

LABELS = ["A1", "A2", "B1", "B2", "C1", "C2", "D1", "D2", "E1", "E2", "F1", "F2"]   # nodes 0..11
TRUTH = {"rod_length": 1.70, "pretension": 140.0, "damping": 210.0}                  # the rest nominal
HEADINGS = (0.0, 2.1, 4.2)
DURATION = 1.5            # s per flop, recorded after the robot settled at rest
NOISE = 0.001             # m of marker noise
JITTER = 3e-4             # s, most a timestamp is off its 100 Hz tick
DROPPED = (47, 112)       # the frames each CSV leaves out
FLOPS = [f"flop{k}" for k in range(len(HEADINGS))]
# the quick mode's settings, appended to identify's and diagnose's commands
QUICK_IDENTIFY = ["--budget", "40", "--latent", "10"]
QUICK_DIAGNOSE = ["--budget", "20", "--passes", "1", "--fit-rounds", "1", "--suspects", "1", "--no-mismatch",
                  "--effects", "actuator_delay"]


def commands(quick: bool = False) -> list[list[str]]:
    """The ``tensegrid`` commands of docs/your-robot.md, in order, run in the folder of the CSVs."""
    data = [f"{name}.nc" for name in FLOPS]
    return [
        *(["convert", f"{name}.csv", f"{name}.nc", "--labels", ",".join(LABELS), "--node-columns", "{label}:{AXIS}",
           "--control-columns", "motor_{a}_{b}", "--time-column", "Time (s)", "--units", "mm", "--up", "y"]
          for name in FLOPS),
        ["check", *data],
        ["identify", *data, "--out", "identify", *(QUICK_IDENTIFY if quick else [])],
        ["simulate", "--from", "identify/result.nc", "--replay", data[-1], "--out", "replay"],
        ["diagnose", *data, "--out", "diagnose", *(QUICK_DIAGNOSE if quick else [])],
        ["simulate", "--model", "diagnose/model.json", "--replay", data[-1], "--out", "replay-diagnosed"],
    ]


def write_mocap_csv(ds: xr.Dataset, path: Path, seed: int) -> Path:
    """``ds`` as a y-up lab exports it: mm, file axes (X, Y, Z) = world (x, z, -y), labelled markers,
    cable commands named by their end markers, a jittered clock and the frames DROPPED left out."""
    rng = np.random.default_rng(seed)
    world = ds["nodes"].values * 1000.0                                              # m -> mm
    file_xyz = np.stack([world[..., 0], world[..., 2], -world[..., 1]], axis=-1)    # z up -> y up
    n = ds.sizes["time"]
    columns: dict[str, np.ndarray] = {"Frame": np.arange(n),
                                      "Time (s)": ds["time"].values + rng.uniform(-JITTER, JITTER, n)}
    for node, label in enumerate(LABELS):
        for a, axis in enumerate("XYZ"):
            columns[f"{label}:{axis}"] = file_xyz[:, node, a]
    for c, (a, b) in enumerate(CABLE_NODES):                                         # cable c joins nodes a, b
        columns[f"motor_{LABELS[a]}_{LABELS[b]}"] = ds["controls"].values[:, c] * 1000.0
    pd.DataFrame(columns).drop(index=list(DROPPED)).to_csv(path, index=False, float_format="%.6f")
    return path


def tensegrid() -> list[str]:
    """How to start this Python's ``tensegrid`` (the script next to it, else the module)."""
    script = Path(sys.executable).with_name("tensegrid")
    return [str(script)] if script.exists() else [sys.executable, "-m", "physics.cli"]


def run(args: list[str], cwd: Path) -> float:
    """Print ``tensegrid ARGS``, run it in ``cwd`` and stop on a failure; the seconds it took."""
    print(f"\n$ tensegrid {shlex.join(args)}", flush=True)
    start = time.perf_counter()
    subprocess.run([*tensegrid(), *args], cwd=cwd, check=True)
    seconds = time.perf_counter() - start
    print(f"({seconds:.0f} s)", flush=True)
    return seconds


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="small budgets, diagnose's quick settings (test suite)")
    parser.add_argument("--out", default="out/your_robot")
    args = parser.parse_args(argv)
    quick = args.quick or os.environ.get("TENSEGRID_QUICK") == "1"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    # 0. The recordings: three flops of the off-nominal robot, as CSV files.
    theta = ParameterSpace.t6().replace(**TRUTH)
    print("the robot:", ", ".join(f"{k} = {v:g}" for k, v in TRUTH.items()), "(SI), the other 12 parameters nominal")
    for k, (name, heading) in enumerate(zip(FLOPS, HEADINGS, strict=True)):
        ds = simulate(theta, controller=FlopController(heading=heading), duration=DURATION, noise=NOISE, seed=k)
        print("wrote", write_mocap_csv(ds, out / f"{name}.csv", seed=k))
        (out / f"{name}.nc").unlink(missing_ok=True)        # convert never overwrites (without --force)

    # 1-5. The commands of docs/your-robot.md.
    seconds = [run(args, out) for args in commands(quick)]
    print("\nseconds per command: " + ", ".join(f"{a[0]} {s:.0f}" for a, s in zip(commands(quick), seconds,
                                                                                 strict=True)))
    print(f"total {sum(seconds):.0f} s; the reports: {out / 'identify' / 'report.html'}, "
          f"{out / 'diagnose' / 'report.html'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
