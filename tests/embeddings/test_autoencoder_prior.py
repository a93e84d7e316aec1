"""The dynamics autoencoder's centre prior: directions the dynamics cannot see decode to the box centre."""
from __future__ import annotations

import numpy as np
import pytest

from embeddings import DynamicsAutoencoder, DynamicsNetwork, EmbeddingError, TrainingConfig, Transitions, load_decoder
from physics.parameters import Parameter, ParameterSpace

SPACE = ParameterSpace(tuple(Parameter(f"p{j}", "1", 1.0, 0.5, 1.5, "") for j in range(4)))


@pytest.fixture(scope="module")
def setting() -> tuple[DynamicsNetwork, Transitions]:
    """Dynamics that depend on p0 and p1 only: y = (p0 - 1) x + (p1 - 1) + small noise."""
    rng = np.random.default_rng(0)
    theta = SPACE.sample(3000, seed=1)
    x = rng.uniform(-1, 1, (3000, 1))
    y = (theta[:, :1] - 1.0) * x + (theta[:, 1:2] - 1.0) + 0.01 * rng.standard_normal((3000, 1))
    data = Transitions(theta, x, y, np.arange(3000), SPACE.names, ("x",), ("y",))
    net = DynamicsNetwork(SPACE, hidden=(32, 32)).fit(data, training=TrainingConfig(epochs=30, batch_size=128, seed=0))
    return net, data


def _unseen_spread(ae: DynamicsAutoencoder) -> float:
    """Std of the decoded p2, p3 over the latent box, in units of the parameter box width."""
    z = ae.bounds[:, 0] + np.random.default_rng(0).random((500, ae.dim)) * np.ptp(ae.bounds, axis=1)
    u = SPACE.to_unit(ae.decode(z))
    return float(np.abs(u[:, 2:] - 0.5).mean())


def test_centre_prior_parks_unseen_directions_at_the_centre(setting, tmp_path) -> None:
    net, data = setting
    training = TrainingConfig(epochs=40, batch_size=128, lr=3e-3, seed=0)
    plain = DynamicsAutoencoder(SPACE, dim=2, hidden=16).fit(net, data, training=training)
    prior = DynamicsAutoencoder(SPACE, dim=2, hidden=16, centre_weight=0.1).fit(net, data, training=training)
    # without the prior p2, p3 go wherever training leaves them; with it they stay near 1/2
    assert _unseen_spread(prior) < 0.03 < 0.1 < _unseen_spread(plain), (_unseen_spread(prior), _unseen_spread(plain))
    # the directions the dynamics see are still followed: decode(encode(θ)) matches p0, p1
    theta = SPACE.sample(200, seed=5)
    back = prior.decode(prior.encode(theta))
    assert np.abs(back[:, :2] - theta[:, :2]).mean() < 0.05
    again = load_decoder(prior.save(tmp_path / "ae.json"), SPACE)
    assert again.centre_weight == 0.1 and again.config() == prior.config()


def test_centre_weight_must_be_a_non_negative_number() -> None:
    with pytest.raises(EmbeddingError, match="centre_weight"):
        DynamicsAutoencoder(SPACE, dim=2, centre_weight=-1.0)


def test_theta_visibility_tells_when_theta_is_below_the_network_error(setting) -> None:
    net, data = setting
    s, e = net.theta_visibility(data)
    assert s > 10 * e                               # y is mostly θ's doing: the network sees θ
    rng = np.random.default_rng(3)
    noise = Transitions(data.theta, data.context, rng.standard_normal((len(data), 1)), data.group, SPACE.names,
                        ("x",), ("y",))
    blind = DynamicsNetwork(SPACE, hidden=(8,)).fit(noise, training=TrainingConfig(epochs=5, batch_size=128, seed=0))
    s, e = blind.theta_visibility(noise)
    assert s < 0.1 * e                              # pure noise: whatever θ does is below the error
