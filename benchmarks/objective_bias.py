"""Is the one-step error right under measurement noise? The minimizer of E(θ) near θ*, in units of its interval.

For each robot (θ* drawn from the T6's ±10 % box with ``seed``), three 3-s flops (headings 0, 2.1,
4.2 rad) of the library's own engine are recorded with ``noise`` metres of position noise and no
velocities (motion capture). For each state estimator (physics.state_estimation: "backward", the
paper's backward difference, and "local-polynomial", the default), Gauss-Newton runs from θ* to the
nearby minimum θ̂ of E (belief.least_squares.gauss_newton_fit, to convergence), and the likelihood's
σ² is measured there (belief.scale.calibrated_scale: block sandwich, noise floor). The row records
z_j = (θ̂_j − θ*_j) / s_j, s_j the local std sqrt diag σ²(JᵀJ)⁻¹: |z_j| > 1.645 puts θ* outside θ̂'s
90 % interval. An objective that is right under noise has |z| ≤ 1.645 in about 90 % of pairs and
no sign shared by most robots.

    .venv/bin/python benchmarks/objective_bias.py --robots 10 --noise 0.0002 0.001 0.003
    .venv/bin/python benchmarks/objective_bias.py --summarize

Rows go to benchmarks/results/objective-bias.jsonl (one per robot, noise and estimator); the
summary prints, per estimator and noise level, the share of pairs inside the 90 % interval, the
median |z| and, per parameter, the median z and how many robots put θ̂ above θ*.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from jsonl_rows import read_rows
from tqdm import tqdm

from belief.least_squares import FitConfig, gauss_newton_fit
from belief.scale import calibrated_scale
from physics import FlopController, ParameterSpace, StateEstimator, TrajectoryObjective, simulate

RESULTS = Path(__file__).parent / "results" / "objective-bias.jsonl"
HEADINGS = (0.0, 2.1, 4.2)
ESTIMATORS = {"backward": StateEstimator(method="backward"), "local-polynomial": StateEstimator()}
Z90 = 1.6448536269514722


def flops(theta: np.ndarray, noise: float, seed: int) -> list:
    """The three noisy 3-s flops of robot ``seed`` (positions only)."""
    return [simulate(theta, controller=FlopController(heading=h), duration=3.0, noise=noise, seed=100 * seed + k)
            for k, h in enumerate(HEADINGS)]


def row(seed: int, noise: float, estimator: str, workers: int) -> dict:
    """One robot, noise level and estimator: θ̂ − θ* in units of θ̂'s local std (module docstring)."""
    space = ParameterSpace.t6()
    truth = space.sample(1, seed=seed)[0]
    start = time.perf_counter()
    with TrajectoryObjective(flops(truth, noise, seed), n_workers=workers, states=ESTIMATORS[estimator]) as E:
        step, residuals = gauss_newton_fit(E, truth, FitConfig(steps=6))
        scale = calibrated_scale(residuals, step.jacobian, noise_floor=E.noise_floor)
        error_truth = E(truth)
    std = step.laplace_std(scale.noise_var)
    z = (step.theta - truth) / std
    return {"seed": seed, "noise_m": noise, "estimator": estimator, "parameters": list(space.names),
            "theta_true": truth.tolist(), "theta_fit": step.theta.tolist(), "std": std.tolist(), "z": z.tolist(),
            "error_true": float(error_truth), "error_fit": float(step.error), "scale": scale.as_dict(),
            "evaluations": int(step.evaluations), "seconds": round(time.perf_counter() - start, 1)}


def summarize(rows: list[dict]) -> str:
    """The table of the module docstring, from the latest row of each (seed, noise, estimator)."""
    latest = {(r["seed"], r["noise_m"], r["estimator"]): r for r in rows}
    names = next(iter(latest.values()))["parameters"] if latest else []
    out = ["| estimator | noise [mm] | robots | pairs inside the 90 % interval | median abs z | adequacy A |",
           "|---|---|---|---|---|---|"]
    groups: dict[tuple[str, float], list[dict]] = {}
    for (_, noise, est), r in sorted(latest.items()):
        groups.setdefault((est, noise), []).append(r)
    for (est, noise), rs in sorted(groups.items()):
        z = np.array([r["z"] for r in rs])
        adequacy = np.median([r["scale"]["adequacy"] or np.nan for r in rs])
        out.append(f"| {est} | {1e3 * noise:g} | {len(rs)} | {np.mean(np.abs(z) <= Z90):.0%} | "
                   f"{np.median(np.abs(z)):.2f} | {adequacy:.2f} |")
    out += ["", "Per parameter: median z, and robots with θ̂ above θ* (of all), per estimator and noise [mm]", ""]
    head = "| parameter | " + " | ".join(f"{e} {1e3 * n:g}" for e, n in sorted(groups)) + " |"
    out += [head, "|---" * (len(groups) + 1) + "|"]
    for j, name in enumerate(names):
        cells = []
        for key in sorted(groups):
            z = np.array([r["z"][j] for r in groups[key]])
            cells.append(f"{np.median(z):+.2f} ({int(np.sum(z > 0))}/{z.size})")
        out.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robots", type=int, default=10, help="robots (seeds first-seed ..)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--noise", type=float, nargs="+", default=[0.0002, 0.001, 0.003], help="position noise [m]")
    parser.add_argument("--estimators", nargs="+", default=list(ESTIMATORS), choices=list(ESTIMATORS))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--summarize", action="store_true", help="print the table from --out and stop")
    args = parser.parse_args()
    if args.summarize:
        print(summarize(read_rows(args.out)))
        return
    jobs = [(s, n, e) for s in range(args.first_seed, args.first_seed + args.robots) for n in args.noise
            for e in args.estimators]
    print(f"{len(jobs)} fits of about 100 simulations each; about {len(jobs) * 25 / 60:.0f} min on 2 cores")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    for seed, noise, est in tqdm(jobs):
        with args.out.open("a") as fh:
            fh.write(json.dumps(row(seed, noise, est, args.workers)) + "\n")
    print(summarize(read_rows(args.out)))


if __name__ == "__main__":
    main()
