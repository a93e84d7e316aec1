"""Active-subspace decoder: it keeps the directions the dynamics respond to and drops the others."""
from __future__ import annotations

import numpy as np
import pytest

from embeddings import ActiveSubspace, DynamicsNetwork, EmbeddingError, TrainingConfig, Transitions, load_decoder
from physics.parameters import Parameter, ParameterSpace

SPACE = ParameterSpace(tuple(Parameter(f"p{j}", "1", 1.0, 0.5, 1.5, "") for j in range(4)))


@pytest.fixture(scope="module")
def fitted() -> ActiveSubspace:
    """Dynamics that depend on p0 and p1 only: y = (p0 - 1) x + 2 (p1 - 1)² + small noise."""
    rng = np.random.default_rng(0)
    theta = SPACE.sample(3000, seed=1)
    x = rng.uniform(-1, 1, (3000, 1))
    y = (theta[:, :1] - 1.0) * x + 2 * (theta[:, 1:2] - 1.0) ** 2 + 0.01 * rng.standard_normal((3000, 1))
    data = Transitions(theta, x, y, np.arange(3000), SPACE.names, ("x",), ("y",))
    net = DynamicsNetwork(SPACE, hidden=(32, 32)).fit(data, training=TrainingConfig(epochs=30, batch_size=128, seed=0))
    return ActiveSubspace.fit(SPACE, net, data, dim=2)


def test_basis_spans_the_parameters_that_act(fitted: ActiveSubspace) -> None:
    W = fitted.W
    assert np.allclose(W.T @ W, np.eye(2), atol=1e-6)
    assert np.linalg.norm(W[2:], axis=0).max() < 0.2, W      # p2, p3 never act
    assert fitted.explained > 0.95


def test_decodes_into_the_box_and_round_trips(fitted: ActiveSubspace, tmp_path) -> None:
    z = fitted.bounds[:, 0] + np.random.default_rng(0).random((100, 2)) * np.ptp(fitted.bounds, axis=1)
    theta = fitted.decode(z)
    assert np.all(theta >= SPACE.lower) and np.all(theta <= SPACE.upper)
    assert np.allclose(fitted.decode(np.zeros(2)), SPACE.nominal)           # the centre of z is the box centre
    back = load_decoder(fitted.save(tmp_path / "active.json"), SPACE)
    assert np.array_equal(back.decode(z), theta) and back.config() == fitted.config()
    with pytest.raises(EmbeddingError, match="basis must be"):
        ActiveSubspace(SPACE, np.ones((3, 2)))
