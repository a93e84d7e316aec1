"""Per-iteration overhead of Algorithm 1 (everything but the simulation): GP fit + acquisition
(prediction on every cell, log EI, arg max) + posterior update (likelihood mode), as the grid grows
from 10^3 to 10^6 cells and the history from 10 to 500 evaluations. Single torch thread.

Target (issue 3): under 1 s per iteration at 11^5 cells and 200 evaluations on one core.

    .venv/bin/python benchmarks/belief_overhead.py            # full table, medians of 3 repeats
    .venv/bin/python benchmarks/belief_overhead.py --quick    # 10^3..11^5 cells, 10..200 evaluations
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from belief import GPSurrogate, Grid, PosteriorConfig, posterior_from_surrogate, select_cells

GRIDS = [(3, 10), (4, 10), (5, 11), (6, 10)]  # (d, points per dim): 1e3, 1e4, 1.6e5, 1e6 cells
HISTORIES = [10, 50, 200, 500]


def _objective(z: np.ndarray) -> np.ndarray:
    """A smooth non-negative test error over the latent box [-1, 1]^d."""
    return np.sum((z - 0.3) ** 2, axis=1) + 0.3 * np.sum(np.sin(3 * z), axis=1) ** 2 + 0.01


def measure(d: int, k: int, n: int, repeats: int) -> dict[str, float]:
    grid = Grid(np.tile([-1.0, 1.0], (d, 1)), points_per_dim=k)
    rng = np.random.default_rng(0)
    idx = rng.choice(grid.size, n, replace=False)
    z = grid.points[idx]
    e = _objective(z)
    avail = np.ones(grid.size, dtype=bool)
    avail[idx] = False
    out: dict[str, list[float]] = {"fit": [], "acquisition": [], "posterior": [], "total": []}
    for _ in range(repeats):
        t0 = time.perf_counter()
        model = GPSurrogate(grid.bounds).fit(z, e)
        t1 = time.perf_counter()
        pred = model.predict(grid.points)
        select_cells(model, grid.points, avail, q=1, prediction=pred)
        t2 = time.perf_counter()
        posterior_from_surrogate(model, grid, config=PosteriorConfig(), noise_var=0.01, prediction=pred)
        t3 = time.perf_counter()
        for key, v in zip(("fit", "acquisition", "posterior", "total"), (t1 - t0, t2 - t1, t3 - t2, t3 - t0)):
            out[key].append(v)
    return {key: float(np.median(v)) for key, v in out.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    torch.set_num_threads(1)
    grids = GRIDS[:3] if args.quick else GRIDS
    hists = HISTORIES[:3] if args.quick else HISTORIES
    print(f"{'cells':>9} {'d':>2} {'evals':>5} {'fit s':>8} {'acq s':>8} {'post s':>8} {'total s':>8}")
    for d, k in grids:
        for n in hists:
            r = measure(d, k, n, args.repeats)
            flag = "  <- target point (goal < 1 s)" if (d, k, n) == (5, 11, 200) else ""
            print(f"{k ** d:>9} {d:>2} {n:>5} {r['fit']:>8.3f} {r['acquisition']:>8.3f} {r['posterior']:>8.3f} "
                  f"{r['total']:>8.3f}{flag}", flush=True)


if __name__ == "__main__":
    main()
