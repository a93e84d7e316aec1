"""The 1-D push toy end to end (Zhu et al. 2018, Sec. IV-C-1): a dynamics network, an autoencoder
trained through it, a 1-D latent monotone in m²μ, and BO in that latent beating BO in (m, μ)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.stats import spearmanr

from belief import Grid, identify
from embeddings import DynamicsAutoencoder, DynamicsNetwork, Identity, TrainingConfig, load_decoder, push_transitions
from physics.push import PushObjective, generate_push_data, push_space

SPACE = push_space()


@pytest.fixture(scope="module")
def trained():
    """(dynamics network, autoencoder, held-out transitions): 20,000 pushes as in the paper, 30 epochs."""
    data = push_transitions(SPACE, 20000, seed=0)
    train, test = data.split(0.1, seed=0)
    dynamics = DynamicsNetwork(SPACE, hidden=(64, 128, 64)).fit(
        train, training=TrainingConfig(epochs=30, batch_size=128, seed=0))
    ae = DynamicsAutoencoder(SPACE, dim=1, hidden=32).fit(
        dynamics, train, training=TrainingConfig(epochs=30, batch_size=128, lr=3e-3, seed=0))
    return dynamics, ae, test


def test_dynamics_network_beats_the_mean_on_held_out_pushes(trained) -> None:
    dynamics, _, test = trained
    score = dynamics.score(test)
    print(f"push dynamics network: held-out MSE {score.mse:.3g} m² vs {score.baseline_mse:.3g} for the mean")
    assert score.ratio < 0.01
    assert all(p.requires_grad for p in dynamics.net.parameters())     # training the autoencoder left it as it was


def test_latent_is_monotone_in_m2mu(trained) -> None:
    _, ae, test = trained
    alpha = ae.encode(test.theta)[:, 0]
    rho = spearmanr(alpha, test.theta[:, 0] ** 2 * test.theta[:, 1]).correlation
    assert abs(rho) >= 0.99, rho
    decoded = ae.decode(np.linspace(*ae.bounds[0], 200)[:, None])
    key = decoded[:, 0] ** 2 * decoded[:, 1]
    assert abs(spearmanr(np.arange(200), key).correlation) >= 0.99       # and so is the decoder


def test_saved_autoencoder_decodes_identically(trained, tmp_path) -> None:
    _, ae, _ = trained
    back = load_decoder(ae.save(tmp_path / "ae.json"), SPACE)
    z = np.linspace(*ae.bounds[0], 11)[:, None]
    assert back.fingerprint() == ae.fingerprint() and np.array_equal(back.decode(z), ae.decode(z))
    assert np.array_equal(back.encode(SPACE.nominal), ae.encode(SPACE.nominal))


def test_bo_in_the_learned_latent_beats_bo_in_m_mu(trained) -> None:
    """Same 15 evaluations, four truths: the best displacement error (E, m²) is lower in the 1-D latent."""
    _, ae, _ = trained
    identity = Identity(SPACE)
    best = {"latent": [], "m, mu": []}
    for seed in range(4):
        truth = SPACE.sample(1, seed=100 + seed)[0]
        J, S = generate_push_data(truth, n=8, seed=seed)
        objective = PushObjective(J, S, space=SPACE)
        for name, decoder, grid in (("latent", ae, Grid.for_decoder(ae, points_per_dim=1001)),
                                    ("m, mu", identity, Grid.for_decoder(identity, points_per_dim=31))):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = identify(objective, decoder, grid, budget=15, seed=seed, progress=False)
            best[name].append(result.best_error)
    print({k: np.round(v, 7).tolist() for k, v in best.items()})
    assert np.median(best["latent"]) < np.median(best["m, mu"])
