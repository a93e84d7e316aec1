"""What the next-recording design buys: its predicted narrowing against the narrowing realized by
recording its choice, and its cost beside identify's.

For each robot (θ* drawn from the T6's ±10 % box with ``seed``), three 3-s flops of the library's
own engine (headings 0, 2.1, 4.2 rad; ``noise`` metres of position noise, no velocities) are
identified with ``preset`` (``--budget`` evaluations, the command line's); then
belief.next_recording scores its 9 candidate flops at the best θ. The candidate it suggests and the
one it scores worst are each recorded at θ* (same noise) and the four flops identified again, same
preset, budget and seed. Narrowing is read from the marginals, for the design and for the runs alike:

    narrowing = Σ_j log(sd_j before / sd_j after)        [nats; sd_j the 1-σ marginal width]

predicted from the design's Laplace widths, realized from P's marginal stds (``Belief.marginals``).
Seconds: identify and the design, each timed in this process, side by side. Rows (one per robot)
go to benchmarks/results/next_recording.jsonl.

    .venv/bin/python benchmarks/next_recording.py --robots 3
    .venv/bin/python benchmarks/next_recording.py --summarize
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
from belief.next_recording import RecordingSuggestion, next_recording
from physics import FlopController, ParameterSpace, TrajectoryObjective, simulate

RESULTS = Path(__file__).parent / "results" / "next_recording.jsonl"
HEADINGS = (0.0, 2.1, 4.2)


def _identified(flops: list, preset: str, budget: int, seed: int, workers: int,
                design: bool) -> tuple[np.ndarray, float, RecordingSuggestion | None, float]:
    """(P's marginal stds (D,), identify's seconds, the design or None, the design's seconds)."""
    with TrajectoryObjective(flops, n_workers=workers) as E:
        start = time.perf_counter()
        result = identify(E, preset=preset, budget=budget, seed=seed)
        seconds = time.perf_counter() - start
        sds = np.asarray(result.belief.marginals()["std"].values, float)
        if not design:
            return sds, seconds, None, 0.0
        start = time.perf_counter()
        suggestion = next_recording(result, E)
        return sds, seconds, suggestion, time.perf_counter() - start


def _recorded(truth: np.ndarray, motion: dict, noise: float, seed: int):
    control = FlopController(motion["heading"], change=motion["change"], n_cables=motion["n_cables"],
                             start=motion["start"], stop=motion["stop"], period=motion["duration"], flops=1)
    return simulate(truth, controller=control, duration=motion["duration"], noise=noise, seed=seed)


def row(seed: int, noise: float, preset: str, budget: int, workers: int) -> dict:
    """One robot's row (module docstring)."""
    truth = ParameterSpace.t6().sample(1, seed=seed)[0]
    flops = [simulate(truth, controller=FlopController(heading=h), duration=3.0, noise=noise, seed=100 * seed + k)
             for k, h in enumerate(HEADINGS)]
    before, seconds, suggestion, design_seconds = _identified(flops, preset, budget, seed, workers, True)
    assert suggestion is not None
    out = {"seed": seed, "noise": noise, "preset": preset, "budget": budget, "identify_s": seconds,
           "design_s": design_seconds}
    now = np.log(np.asarray(suggestion.marginal_pct))
    for name, score in (("best", suggestion.scores[0]), ("worst", suggestion.scores[-1])):
        extra = _recorded(truth, score.motion.as_dict(), noise, 100 * seed + 9)
        after, _, _, _ = _identified(flops + [extra], preset, budget, seed, workers, False)
        out[name] = {"motion": score.motion.label, "gain": score.gain,
                     "predicted": float(np.sum(now - np.log(np.asarray(score.marginal_pct)))),
                     "realized": float(np.sum(np.log(before / after)))}
    return out


def summarize(rows: list[dict]) -> str:
    """The table of the module docstring: per robot, predicted and realized narrowing of the suggested
    and the worst candidate, and the seconds."""
    lines = ["| robot | suggested: gain, predicted, realized [nats] | worst: gain, predicted, realized | "
             "identify s | design s |", "|---|---|---|---|---|"]
    for r in rows:
        b, w = r["best"], r["worst"]
        lines.append(f"| {r['seed']} ({r['preset']}, {1e3 * r['noise']:g} mm) | {b['gain']:.2f}, {b['predicted']:.2f}, "
                     f"{b['realized']:.2f} | {w['gain']:.2f}, {w['predicted']:.2f}, {w['realized']:.2f} | "
                     f"{r['identify_s']:.0f} | {r['design_s']:.0f} |")
    if rows:
        ratio = np.median([r["design_s"] / r["identify_s"] for r in rows])
        lines.append(f"\nmedian design / identify time: {ratio:.2f}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robots", type=int, default=3)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--noise", type=float, default=0.001, help="position noise [m]")
    parser.add_argument("--preset", default="handoff-gn")
    parser.add_argument("--budget", type=int, default=60, help="the command line's default")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--summarize", action="store_true")
    args = parser.parse_args()
    if args.summarize:
        print(summarize(read_rows(args.out)))
        return
    seeds = range(args.first_seed, args.first_seed + args.robots)
    print(f"{len(seeds)} robots, 3 identifications each; about {3 * len(seeds) * 1.5:.0f} min on 2 cores")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    for seed in tqdm(seeds):
        result = row(seed, args.noise, args.preset, args.budget, args.workers)
        with args.out.open("a") as fh:
            fh.write(json.dumps(result) + "\n")
    print(summarize(read_rows(args.out)))


if __name__ == "__main__":
    main()
