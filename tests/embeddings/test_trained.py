"""Trained decoders: in the box, deterministic for a seed, identical after save/load, weights in the fingerprint."""
from __future__ import annotations

import json

import numpy as np
import pytest

from belief import Grid, identify
from belief.errors import JournalError
from embeddings import VAE, EmbeddingError, TrainingConfig, decoder_from_config, load_decoder
from physics.parameters import ParameterSpace
from physics.push import PushObjective, generate_push_data, push_space

SPACE = ParameterSpace.t6()
FAST = TrainingConfig(epochs=3, batch_size=256, seed=0)


@pytest.fixture(scope="module")
def vae() -> VAE:
    return VAE(SPACE, dim=5, hidden=64).fit(2000, training=FAST)


def test_vae_decodes_into_the_box(vae: VAE) -> None:
    assert vae.bounds.tolist() == [[-3.0, 3.0]] * 5
    z = np.random.default_rng(0).uniform(-3, 3, (200, 5))
    theta = vae.decode(z)
    assert theta.shape == (200, 15)
    assert np.all(theta >= SPACE.lower) and np.all(theta <= SPACE.upper)
    assert np.ptp(SPACE.to_unit(theta), axis=0).min() > 0.05      # the decoder is not constant
    with pytest.raises(EmbeddingError, match="must lie in the box"):
        vae.decode(np.full(5, 3.5))


def test_same_seed_same_weights_other_seed_other_weights(vae: VAE) -> None:
    again = VAE(SPACE, dim=5, hidden=64).fit(2000, training=FAST)
    other = VAE(SPACE, dim=5, hidden=64).fit(2000, training=TrainingConfig(epochs=3, seed=1))
    assert again.fingerprint() == vae.fingerprint() and again.config() == vae.config()
    assert other.fingerprint() != vae.fingerprint()
    z = np.zeros((1, 5))
    assert np.array_equal(again.decode(z), vae.decode(z)) and not np.array_equal(other.decode(z), vae.decode(z))


def test_save_and_load_decode_identically(vae: VAE, tmp_path) -> None:
    path = vae.save(tmp_path / "vae.json")
    back = load_decoder(path, SPACE)
    assert isinstance(back, VAE) and back.fingerprint() == vae.fingerprint() and back.config() == vae.config()
    z = np.random.default_rng(1).uniform(-3, 3, (50, 5))
    assert np.array_equal(back.decode(z), vae.decode(z))
    assert np.array_equal(back.encode(SPACE.nominal), vae.encode(SPACE.nominal))    # the encoder travels too
    assert back.history == vae.history and len(back.history) == 3
    assert np.array_equal(decoder_from_config(json.loads(json.dumps(vae.config())), SPACE).decode(z), vae.decode(z))


def test_untrained_altered_or_foreign_files_are_refused(vae: VAE, tmp_path) -> None:
    with pytest.raises(EmbeddingError, match="not trained"):
        VAE(SPACE).decode(np.zeros(5))
    record = json.loads(vae.save(tmp_path / "v.json").read_text())
    tensors = record["decoder"]["weights"]["tensors"]
    name = next(iter(tensors))
    tensors[name][1] = tensors[name][1][:-8] + "AAAAAAA="
    (tmp_path / "bad.json").write_text(json.dumps(record))
    with pytest.raises(EmbeddingError, match="sha256"):
        load_decoder(tmp_path / "bad.json", SPACE)
    with pytest.raises(EmbeddingError, match="no decoder file"):
        load_decoder(tmp_path / "missing.json", SPACE)
    with pytest.raises(EmbeddingError, match="trained on the parameters"):
        load_decoder(tmp_path / "v.json", push_space())


def test_a_journal_refuses_a_different_model(tmp_path) -> None:
    """The problem fingerprint carries the weights: resuming with another trained decoder is refused."""
    space = push_space()
    J, S = generate_push_data(np.array([1.0, 0.4]), n=6, noise_std=0.01, seed=0)
    objective = PushObjective(J, S, space=space, noise_std=0.01)
    first = VAE(space, dim=1, hidden=16).fit(500, training=TrainingConfig(epochs=2, seed=0))
    second = VAE(space, dim=1, hidden=16).fit(500, training=TrainingConfig(epochs=2, seed=1))
    journal = tmp_path / "run.sqlite"
    identify(objective, first, Grid.for_decoder(first, points_per_dim=21), budget=4, seed=0, journal=journal,
             progress=False)
    with pytest.raises(JournalError, match="decoder"):
        identify(objective, second, Grid.for_decoder(second, points_per_dim=21), budget=4, seed=0, journal=journal,
                 progress=False)
