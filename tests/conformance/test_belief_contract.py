"""Every SamplingBelief (belief.sampling, what planners consume) passes the same checks.

A new kind of belief is one line in IMPLEMENTATIONS (a factory returning an instance).
"""
from __future__ import annotations

import numpy as np
import pytest

from belief import Belief, Grid, SamplingBelief
from embeddings import Identity
from physics.parameters import ParameterSpace
from physics.push import push_space


def _grid_belief() -> Belief:
    dec = Identity(push_space())
    grid = Grid.for_decoder(dec, points_per_dim=5)
    weights = np.exp(-np.arange(grid.size) / 1.5)
    return Belief.from_posterior(grid.to_dataarray(weights / weights.sum(), name="P"), dec, grid)


def _point_belief():
    from planners.robust import PointBelief

    return PointBelief(ParameterSpace.t6().nominal)


IMPLEMENTATIONS = [
    pytest.param(_grid_belief, id="Belief"),
    pytest.param(_point_belief, id="PointBelief"),
]


@pytest.fixture(scope="module", params=IMPLEMENTATIONS)
def belief(request) -> SamplingBelief:
    return request.param()


def test_support_and_probabilities(belief: SamplingBelief) -> None:
    assert isinstance(belief, SamplingBelief) and isinstance(belief.space, ParameterSpace)
    theta, p = np.asarray(belief.theta), np.asarray(belief.p)
    assert theta.ndim == 2 and theta.shape[1] == belief.space.dim and np.isfinite(theta).all()
    assert p.shape == (theta.shape[0],) and (p >= 0).all() and p.sum() == pytest.approx(1.0)


def test_draws_are_rows_of_the_support_and_a_function_of_the_seed(belief: SamplingBelief) -> None:
    draws = belief.sample(40, seed=3)
    assert draws.shape == (40, belief.space.dim)
    support = {tuple(row) for row in np.asarray(belief.theta)}
    assert all(tuple(row) in support for row in draws)
    np.testing.assert_array_equal(belief.sample(40, seed=3), draws)
    np.testing.assert_array_equal(belief.sample(40, seed=np.random.default_rng(3)), draws)
    mass = np.asarray(belief.p)
    if (mass > 0).sum() > 1:                            # draws follow p: the likeliest row is the commonest
        rows = [tuple(row) for row in np.asarray(belief.theta)]
        counts = [sum(tuple(d) == row for d in belief.sample(400, seed=0)) for row in rows]
        assert int(np.argmax(counts)) == int(np.argmax(mass))
