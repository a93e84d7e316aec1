"""Where the local stage ends against the minimum of E nearest θ*: one valley or two basins?

For each own-engine robot of benchmarks/sharpness.py (its latest ``local`` row at the noise given)
and the Gauss-Newton minimum of E started from θ* on the same data (benchmarks/objective_bias.py,
local-polynomial states), E along the straight line from the local stage's end point a (t = 0) to
that minimum b (t = 1), in nats of the row's σ², and the parameters where a and b differ by more
than 2 % of b. A barrier of a few nats between two ends of equal E is two basins; a line that
stays within a nat is one flat valley. Either way a posterior built around a alone (its
curvature, its profiles) cannot hold b, and with b, θ*. Two more columns: what the Gauss-Newton
quadratic at a (its Jacobian, the row's σ²) prices the move a -> b at, and how many nats a longer
Gauss-Newton fit from a (12 steps, stopping under 0.1 nat) gains, with its simulations.

    .venv/bin/python benchmarks/basins.py --robots 3 --noise 0.001
"""
from __future__ import annotations

import argparse

import numpy as np
from jsonl_rows import read_rows
from objective_bias import RESULTS as BIAS_ROWS
from sharpness import RESULTS as SHARP_ROWS
from sharpness import _data

from belief.least_squares import FitConfig, gauss_newton_fit, gauss_newton_step
from physics import TrajectoryObjective

STEPS = np.linspace(-0.2, 1.2, 15)


def _latest(rows: list[dict], **match: object) -> dict[int, dict]:
    return {r["seed"]: r for r in rows if all(r.get(k) == v for k, v in match.items())}


def line(seed: int, noise: float, end: dict, fit: dict, workers: int) -> str:
    """One robot's line of the table."""
    truth, flops, names = _data("own", seed, noise)
    a, b = np.asarray(end["theta_end"]), np.asarray(fit["theta_fit"])
    with TrajectoryObjective(flops, n_workers=workers) as E:
        errors = E.evaluate_batch(np.array([a + t * (b - a) for t in STEPS])).errors
        step = gauss_newton_step(E, a)
        du = (b - a) / step.width
        priced = 0.5 * float(np.sum((step.jacobian @ du) ** 2)) / end["noise_var"]
        longer, _ = gauss_newton_fit(E, a, FitConfig(steps=12, nats=0.1))
    nats = (errors - errors[int(np.argmin(np.abs(STEPS)))]) / (2 * end["noise_var"])
    gained = (step.start_error - longer.error) / (2 * end["noise_var"])
    inner = nats[(STEPS > 0) & (STEPS < 1)]
    differ = ", ".join(f"{n} {100 * (x - y) / y:+.0f} %" for n, x, y in zip(names, a, b, strict=True)
                       if abs(x - y) > 0.02 * abs(y))
    return (f"| {seed} | {nats[np.argmin(np.abs(STEPS - 1))]:+.1f} | {inner.max():+.1f} | {inner.min():+.1f} | "
            f"{priced:.0f} | {gained:.1f} ({longer.evaluations}) | {differ} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robots", type=int, default=3)
    parser.add_argument("--noise", type=float, default=0.001)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    ends = _latest(read_rows(SHARP_ROWS), scenario="own", config="local", noise_m=args.noise)
    fits = _latest(read_rows(BIAS_ROWS), estimator="local-polynomial", noise_m=args.noise)
    print("| robot | E(b) − E(a) [nats] | highest between | lowest between | quadratic at a prices a -> b [nats] | "
          "longer fit from a gains [nats] (simulations) | a against b |\n|---|---|---|---|---|---|---|")
    for seed in range(args.robots):
        if seed in ends and seed in fits:
            print(line(seed, args.noise, ends[seed], fits[seed], args.workers))


if __name__ == "__main__":
    main()
