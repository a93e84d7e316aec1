"""Shared fixtures of the planners tests: tiny beliefs over the T6 space (no identification run)."""
from __future__ import annotations

import numpy as np
import pytest

from belief.belief import Belief
from belief.grid import SobolCandidates
from embeddings import Identity
from physics.parameters import ParameterSpace


def tiny_belief(n: int = 4, p: "np.ndarray | None" = None, seed: int = 0) -> Belief:
    """A Belief over ``n`` Sobol cells of the T6's ±10 % box, P uniform unless ``p`` is given."""
    dec = Identity(ParameterSpace.t6())
    grid = SobolCandidates.for_decoder(dec, n=n, seed=seed)
    probs = np.full(grid.size, 1.0 / grid.size) if p is None else np.asarray(p, dtype=float)
    return Belief.from_posterior(grid.to_dataarray(probs, name="P"), dec, grid)


@pytest.fixture
def belief4() -> Belief:
    return tiny_belief(4)


@pytest.fixture
def make_belief():
    """Factory: tiny_belief(n, p, seed)."""
    return tiny_belief


@pytest.fixture
def dynamic_cells() -> Belief:
    """Three cells that differ only in parameters that act on motion (damping, motor speed, ±10 %):
    at rest, and while barely moving, they look alike; a flop tells them apart."""
    space = ParameterSpace.t6()
    b = tiny_belief(3)
    theta = np.tile(space.nominal, (3, 1))
    theta[:, space.names.index("damping")] = [180.0, 200.0, 220.0]
    theta[:, space.names.index("targetVelocity")] = [1.35, 1.5, 1.65]
    return Belief(b.P, theta, space, decoder_config=b.decoder_config, grid_config=b.grid_config)
