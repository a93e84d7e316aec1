"""The mismatch floor: how far DART at the nominal θ is from the foreign testbed's nominal robot,
next to how far it is from itself.

Rows (noise-free observations, 3 s flops at 100 Hz, the three flops and the held-out flop):

- ``testbed``: testbed nominal data sets (benchmarks/testbed, Bullet), seeds 0..S-1;
- ``mujoco``: the same robot and flops in MuJoCo (testbed.mujoco_robot, the third engine), with
  ``--engines bullet mujoco``;
- ``mujoco-native``: the robot rebuilt with MuJoCo's own tendons and actuators
  (testbed.mujoco_native, sharing no robot code), with ``--engines mujoco-native``;
- ``dart dt/2``: DART's own nominal flops simulated with a 0.5 ms step (the model runs at 1 ms):
  what DART differs from itself by when only the integration changes.

Columns: one-step RMS residual per coordinate [mm] (E with horizon 1, squared loss, over the
residual count), and the open-loop drift [mm] (mean node distance between one free rollout from
the first sample and the observation) at 0.2, 0.3, 0.5 and 1.0 s after the start of the recording
(the flops' commands start at 0.2 s), and the mean height of the three lowest nodes in the
first sample, at rest [mm]. The last line gives the medians' ratios.

    .venv/bin/python benchmarks/testbed_floor.py --seeds 3
    .venv/bin/python benchmarks/testbed_floor.py --seeds 3 --engines bullet mujoco
"""
from __future__ import annotations

import argparse

import numpy as np
import xarray as xr
from tqdm import tqdm

from physics import FlopController, ModelOptions, ParameterSpace, TrajectoryObjective, load_trajectory, simulate
from testbed.datasets import ENGINES, cached_dataset

TIMES = (0.2, 0.3, 0.5, 1.0)
LABEL = {"bullet": "testbed", "mujoco": "mujoco", "mujoco-native": "mujoco-native"}


def floor_row(ds: xr.Dataset, theta: np.ndarray) -> tuple[float, ...]:
    """(one-step RMS [mm], drift at each of TIMES [mm], resting height of the lowest three nodes
    [mm]) of DART at ``theta`` on one trajectory."""
    one_step = TrajectoryObjective(ds, loss="squared", n_workers=0)
    rms = np.sqrt(one_step(theta) / one_step.n_observations) * 1e3
    rollout = TrajectoryObjective(ds, horizon="rollout", n_workers=0).predictions(theta)[0].values
    distance = np.linalg.norm(rollout - ds["nodes"].values, axis=2).mean(axis=1)
    t = ds["time"].values - ds["time"].values[0]
    rest = float(np.sort(ds["nodes"].values[0, :, 2])[:3].mean()) * 1e3
    return (float(rms), *(float(distance[np.argmin(np.abs(t - x))]) * 1e3 for x in TIMES), rest)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=3, help="testbed nominal data sets (default 3)")
    parser.add_argument("--engines", nargs="+", choices=ENGINES, default=["bullet"],
                        help="the foreign engines to compare (default: bullet, the testbed)")
    args = parser.parse_args()
    nominal = ParameterSpace.t6().nominal
    rows: dict[str, list[tuple[float, ...]]] = {LABEL[e]: [] for e in args.engines}
    rows["dart dt/2"] = []
    for engine in args.engines:
        for seed in tqdm(range(args.seeds), desc=LABEL[engine]):
            for path in cached_dataset("nominal", seed, noise=0.0, engine=engine).values():
                rows[LABEL[engine]].append(floor_row(load_trajectory(path), nominal))
    for heading in tqdm((0.3, 2.4, 4.5, 1.35), desc="dart dt/2"):
        ds = simulate(controller=FlopController(heading=heading), duration=3.0, options=ModelOptions(dt=5e-4),
                      record_velocities=False)
        rows["dart dt/2"].append(floor_row(ds, nominal))
    print(f"{'source':10s} {'n':>3s} {'one-step RMS mm':>16s} " + " ".join(f"{f'drift {t:g}s mm':>14s}" for t in TIMES) + f" {'rest height mm':>15s}")
    medians = {}
    for name, values in rows.items():
        arr = np.array(values)
        medians[name] = np.median(arr, axis=0)
        cells = " ".join(f"{m:8.3f} [{lo:.3g}-{hi:.3g}]" for m, lo, hi in zip(medians[name], arr.min(0), arr.max(0)))
        print(f"{name:10s} {len(arr):3d} {cells}   (median [min-max])")
    for engine in args.engines:
        ratio = medians[LABEL[engine]] / medians["dart dt/2"]
        print(f"ratio {LABEL[engine]} / dart dt/2 (medians): " + ", ".join(f"{r:.0f}x" for r in ratio))


if __name__ == "__main__":
    main()
