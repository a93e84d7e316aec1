"""Calibration: over synthetic push-toy problems with known truth and noise, the 90 % credible region
of P contains the truth about 90 % of the time.

P is a posterior over grid cells with a uniform prior over the cells, so the truth is drawn from that
prior (a random cell centre); the exact discrete Bayes posterior is then calibrated by construction,
and any miss measures the error of the GP surrogate and of the small evaluation budget.

Run standalone for the figure quoted in docs/identification.md::

    .venv/bin/python tests/belief/test_calibration.py 100
"""
from __future__ import annotations

import sys

import numpy as np

from belief import Grid, credible_mask, identify
from embeddings import Identity
from physics.push import PushError, generate_push_data, push_space

NOISE_STD = 0.05  # m, on displacements of ~0.1-10 m


def coverage(n_problems: int, *, budget: int = 30, points_per_dim: int = 31, level: float = 0.9,
             first_seed: int = 1000, exact: list[bool] | None = None) -> tuple[float, list[bool]]:
    """Fraction of problems whose true θ (its nearest cell) lies in the ``level`` HPD region of P.

    ``exact``: if a list is given, it receives the same hit/miss for the exact grid posterior
    P(cell) ∝ exp(-E(cell) / (2 sigma^2)) computed from E on every cell (the reference a perfect
    surrogate would reach; affordable only for a toy).
    """
    space = push_space()
    dec = Identity(space)
    grid = Grid.for_decoder(dec, points_per_dim=points_per_dim)
    hits = []
    for k in range(n_problems):
        rng = np.random.default_rng(first_seed + k)
        truth = dec.decode(grid.points[rng.integers(grid.size)])  # θ* ~ the prior: uniform over the cells
        J, S = generate_push_data(truth, n=8, noise_std=NOISE_STD, seed=rng)
        obj = PushError(J, S, space=space, noise_std=NOISE_STD)
        res = identify(obj, dec, grid, budget=budget, seed=k, progress=False)
        mask = credible_mask(res.posterior.values.ravel(), level=level)
        cell = grid.nearest(dec.encode(truth))[0]
        hits.append(bool(mask[cell]))
        if exact is not None:
            E = np.array([obj(th) for th in dec.decode(grid.points)])
            exact.append(bool(credible_mask(np.exp(-(E - E.min()) / (2 * NOISE_STD**2)), level=level)[cell]))
    return float(np.mean(hits)), hits


def test_90_percent_region_covers_the_truth_about_90_percent_of_the_time() -> None:
    frac, hits = coverage(20)
    assert 0.7 <= frac <= 1.0, hits


if __name__ == "__main__":
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    budget = int(sys.argv[2]) if len(sys.argv) > 2 else 30
    ref: list[bool] = []
    for name, hits in (("GP posterior (identify)", coverage(n, budget=budget, exact=ref)[1]), ("exact grid posterior", ref)):
        frac = float(np.mean(hits))
        half = 1.96 * np.sqrt(frac * (1 - frac) / n)
        print(f"budget {budget}, {name}: the 90% credible region covers the truth in {sum(hits)}/{n} = {frac:.3f} "
              f"(95% binomial CI {frac - half:.3f}-{frac + half:.3f})")
