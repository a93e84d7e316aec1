"""BO beats random search at equal evaluations on Branin embedded in 15-D (REMBO) and on Hartmann-6."""
from __future__ import annotations

import numpy as np

from belief import Grid, SobolCandidates, identify
from embeddings import REMBO, Identity

SEEDS = (0, 1, 2)


def _random_search(f, budget: int, seed: int) -> float:
    full = Identity(f.space)
    cand = SobolCandidates.for_decoder(full, n=20000, seed=seed)
    return identify(f, full, cand, budget=budget, seed=seed, proposer="random", posterior=None,
                    progress=False).best_error - f.minimum


def test_rembo_bo_beats_random_search_on_branin_in_15d(branin15) -> None:
    """Wang et al. 2016's setting: 2 active of 15 dimensions, REMBO with d = 2, 30 evaluations."""
    bo, rs = [], []
    for seed in SEEDS:
        dec = REMBO(branin15.space, dim=2, seed=seed)
        res = identify(branin15, dec, Grid.for_decoder(dec, points_per_dim=41), budget=30, n_init=8, seed=seed,
                       posterior=None, progress=False)
        bo.append(res.best_error - branin15.minimum)
        rs.append(_random_search(branin15, 30, seed))
    assert np.all(np.array(bo) >= -1e-6) and np.all(np.array(rs) >= -1e-6)  # regret is a regret
    assert np.mean(bo) < 0.5 * np.mean(rs), (bo, rs)
    assert sum(b < r for b, r in zip(bo, rs)) >= 2, (bo, rs)


def test_bo_beats_random_search_on_hartmann6(hartmann6) -> None:
    bo, rs = [], []
    for seed in SEEDS:
        dec = Identity(hartmann6.space)
        cand = SobolCandidates.for_decoder(dec, n=20000, seed=seed)
        res = identify(hartmann6, dec, cand, budget=40, n_init=6, seed=seed, posterior=None, progress=False)
        bo.append(res.best_error - hartmann6.minimum)
        rs.append(_random_search(hartmann6, 40, seed))
    assert np.mean(bo) < np.mean(rs), (bo, rs)
    assert sum(b < r for b, r in zip(bo, rs)) >= 2, (bo, rs)
