"""As sharp as the data allow, and honest: the default identification against the previous default.

Scenario ``own``: for each robot (θ* drawn from the T6's ±10 % box with ``seed``), three 3-s flops
(headings 0, 2.1, 4.2 rad) of the library's own engine, recorded with ``noise`` metres of position
noise and no velocities. Scenario ``testbed``: the foreign robot's ``perturbed`` data set of that
seed (benchmarks/testbed, Bullet; its three flops, ``noise`` as the marker noise), scored on the
12 parameters that act there. Three configurations identify them with the same budget:

- ``default``: the default preset (handoff-gn: the global belief, σ² by the "ess" rule with its
  model-error floor δ₀ = 0.2, one finishing Gauss-Newton step) on the one-step error from
  local-polynomial states (physics.state_estimation);
- ``previous``: the same with the backward-difference states (the default before);
- ``local``: the preset handoff-local: the local stage (belief.local_belief) at the data's
  resolution, σ² measured from the data (belief.scale), on local-polynomial states.

With ``--rod-mass SD`` the rod mass is given (physics.measurements, ``rod_mass`` with a relative sd).
The "local width" of a parameter is its std from the Laplace approximation at θ* with the σ²
the block sandwich measures there (belief.scale; the measurement rows added), the width the data
allow. Rows (one per robot, configuration and noise) go to benchmarks/results/sharpness.jsonl.

    .venv/bin/python benchmarks/sharpness.py --robots 10 --noise 0.001 --rod-mass 0.005
    .venv/bin/python benchmarks/sharpness.py --scenario testbed --robots 10 --noise 0.0002 --rod-mass 0.005
    .venv/bin/python benchmarks/sharpness.py --summarize
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from jsonl_rows import read_rows
from tqdm import tqdm

from belief import identify
from belief.least_squares import gauss_newton_step
from belief.scale import calibrated_scale
from physics import FlopController, ParameterSpace, StateEstimator, TrajectoryObjective, load_trajectory, simulate
from physics.measurements import Measurement, MeasurementPrior, rod_mass

RESULTS = Path(__file__).parent / "results" / "sharpness.jsonl"
HEADINGS = (0.0, 2.1, 4.2)
CONFIGS = ("default", "previous", "local")


def _flops(theta: np.ndarray, noise: float, seed: int) -> list:
    return [simulate(theta, controller=FlopController(heading=h), duration=3.0, noise=noise, seed=100 * seed + k)
            for k, h in enumerate(HEADINGS)]


def _local_width(E: TrajectoryObjective, truth: np.ndarray, prior: MeasurementPrior | None) -> np.ndarray:
    """std (D,) of the Laplace approximation at θ* with the block sandwich's σ² (module docstring)."""
    step = gauss_newton_step(E, truth)
    residuals = E.residuals(truth)
    sigma2 = calibrated_scale(residuals, step.jacobian, noise_floor=E.noise_floor).blocks_var
    F = step.jacobian.T @ step.jacobian / sigma2
    if prior is not None:
        G = prior.jacobian(truth)
        F = F + G.T @ G
    cov = np.linalg.pinv(F, rcond=1e-12)
    return np.sqrt(np.clip(np.diag(cov), 0.0, None)) * step.width


def _data(scenario: str, seed: int, noise: float) -> tuple[np.ndarray, list, list[str]]:
    """(θ* (15,), the three flops, the names scored) of one robot."""
    space = ParameterSpace.t6()
    if scenario == "own":
        truth = space.sample(1, seed=seed)[0]
        return truth, _flops(truth, noise, seed), list(space.names)
    from testbed.datasets import cached_dataset
    from testbed.params import ACTIVE

    files = cached_dataset("perturbed", seed, noise=noise)
    theta = json.loads((files["flop_0"].parent / "truth.json").read_text())["theta"]
    truth = space.as_array({**dict(zip(space.names, space.nominal, strict=True)), **theta})
    return truth, [load_trajectory(files[f"flop_{k}"]) for k in range(3)], list(ACTIVE)


def row(scenario: str, seed: int, noise: float, config: str, rod_sd: float | None, budget: int,
        workers: int) -> dict:
    space = ParameterSpace.t6()
    truth, flops, scored = _data(scenario, seed, noise)
    prior = None
    if rod_sd is not None:
        mass = float(rod_mass(space, truth[None])[0])
        prior = MeasurementPrior(space, (Measurement("rod_mass", mass, rod_sd * mass),))
    states = StateEstimator(method="backward") if config == "previous" else StateEstimator()
    preset = "handoff-local" if config == "local" else "handoff-gn"
    start = time.perf_counter()
    with TrajectoryObjective(flops, n_workers=workers, states=states) as E:
        result = identify(E, budget=budget, seed=seed, preset=preset, progress=False, measurements=prior)
        seconds = time.perf_counter() - start
        local = _local_width(E, truth, prior) if config != "previous" and scenario == "own" else None
        error_true = float(E(truth))
    m = result.belief.marginals()
    out = {"scenario": scenario, "seed": seed, "noise_m": noise, "config": config, "rod_mass_sd": rod_sd,
           "budget": budget, "parameters": list(space.names), "scored": scored, "theta_true": truth.tolist(),
           "theta_end": np.asarray(result.best_theta.values).tolist(), "lower": m["lower"].values.tolist(),
           "upper": m["upper"].values.tolist(), "verdicts": list(result.belief.verdict),
           "noise_var": result.belief.attrs.get("noise_var"), "seconds": round(seconds, 1),
           "error_true": error_true, "error_end": float(result.best_error),
           "scale": result.belief.attrs.get("noise"),
           "starts": [s.get("error") for s in (result.belief.attrs.get("local_fit") or {}).get("starts", [])],
           "evaluations": int(result.n_evaluations), "local_stage": result.config.get("local_stage")}
    if local is not None:
        out["local_std"] = local.tolist()
    return out


def _scored(r: dict) -> np.ndarray:
    """Mask (D,) of the parameters a row is scored on."""
    return np.array([n in r.get("scored", r["parameters"]) for n in r["parameters"]])


def _claims(rows: list[dict]) -> tuple[int, int]:
    """(claims holding θ*, claims): identified or weakly identified intervals of scored parameters."""
    held = total = 0
    for r in rows:
        t, lo, hi = (np.asarray(r[k]) for k in ("theta_true", "lower", "upper"))
        claim = np.array([v != "not identified" for v in r["verdicts"]]) & _scored(r)
        total += int(claim.sum())
        held += int(np.sum(claim & (lo <= t) & (t <= hi)))
    return held, total


def summarize(rows: list[dict]) -> str:
    """Per configuration and noise: identified counts, coverage, claims, width over the local width."""
    latest = {(r.get("scenario", "own"), r["seed"], r["noise_m"], r["config"], r["rod_mass_sd"]): r for r in rows}
    groups: dict[tuple, list[dict]] = {}
    for (scenario, _, noise, config, sd), r in sorted(latest.items(), key=lambda kv: str(kv[0])):
        groups.setdefault((scenario, config, noise, sd), []).append(r)
    lines = ["| robots | configuration | noise [mm] | rod mass sd | n | identified or weakly per robot (median) | "
             "90 % intervals holding θ* | claims holding θ* | θ at the end inside its interval | "
             "median width / local width | median seconds |", "|---" * 11 + "|"]
    for (scenario, config, noise, sd), rs in sorted(groups.items(), key=lambda kv: str(kv[0])):
        keep = _scored(rs[0])
        t = np.array([r["theta_true"] for r in rs])[:, keep]
        lo, hi = np.array([r["lower"] for r in rs])[:, keep], np.array([r["upper"] for r in rs])[:, keep]
        end = np.array([r["theta_end"] for r in rs])[:, keep]
        counts = [sum(v != "not identified" for v, k in zip(r["verdicts"], keep, strict=True) if k) for r in rs]
        held, total = _claims(rs)
        ratio = "-"
        if all("local_std" in r for r in rs):
            s = np.array([r["local_std"] for r in rs])[:, keep]
            box = (np.array(ParameterSpace.t6().upper) - np.array(ParameterSpace.t6().lower))[keep]
            seen = s < 0.1 * box                                   # a width the data set, not the box
            ratio = f"{np.median(((hi - lo) / (2 * 1.6449 * s))[seen]):.2f}" if seen.any() else "-"
        lines.append(f"| {scenario} | {config} | {1e3 * noise:g} | {sd if sd is not None else '-'} | {len(rs)} | "
                     f"{np.median(counts):.0f} | {np.mean((lo <= t) & (t <= hi)):.0%} | {held}/{total} | "
                     f"{np.mean((lo <= end) & (end <= hi)):.0%} | {ratio} | "
                     f"{np.median([r['seconds'] for r in rs]):.0f} |")
    names = next(iter(latest.values()))["parameters"] if latest else []
    lines += ["", "Per parameter: robots where it is identified / weakly identified", "",
              "| parameter | " + " | ".join(f"{w} {c} {1e3 * n:g} mm" for w, c, n, _ in sorted(groups, key=str)) + " |",
              "|---" * (len(groups) + 1) + "|"]
    for j, name in enumerate(names):
        cells = []
        for key in sorted(groups, key=str):
            v = [r["verdicts"][j] for r in groups[key]]
            cells.append(f"{v.count('identified')} / {v.count('weakly identified')}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenario", choices=["own", "testbed"], default="own")
    parser.add_argument("--robots", type=int, default=10)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--noise", type=float, nargs="+", default=[0.001], help="position noise [m]")
    parser.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=CONFIGS)
    parser.add_argument("--rod-mass", type=float, default=None, metavar="SD",
                        help="give the rod mass with this relative sd (e.g. 0.005)")
    parser.add_argument("--budget", type=int, default=60, help="the command line's default")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--summarize", action="store_true")
    args = parser.parse_args()
    if args.summarize:
        print(summarize(read_rows(args.out)))
        return
    jobs = [(s, n, c) for s in range(args.first_seed, args.first_seed + args.robots) for n in args.noise
            for c in args.configs]
    print(f"{len(jobs)} identifications; about {len(jobs) * 2.5:.0f} min on 2 cores")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    for seed, noise, config in tqdm(jobs):
        result = row(args.scenario, seed, noise, config, args.rod_mass, args.budget, args.workers)
        with args.out.open("a") as fh:
            fh.write(json.dumps(result) + "\n")
    print(summarize(read_rows(args.out)))


if __name__ == "__main__":
    main()
