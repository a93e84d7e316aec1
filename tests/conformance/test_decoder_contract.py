"""Every decoder in embeddings passes the same checks (the Decoder contract, embeddings.base).

A new decoder is one line in IMPLEMENTATIONS: a factory returning a :class:`Case` (the decoder
and whether decode(encode(θ)) = θ exactly). Trained decoders are fitted for a few epochs on a few
rows: the checks are about the contract, not about what the networks learned.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pytest
from scipy.stats import qmc

from embeddings import REMBO, Decoder, EmbeddingError, EncodingDecoder, Identity, decoder_from_config, load_decoder
from embeddings.registry import registered_kinds
from physics.parameters import ParameterSpace
from physics.push import push_space


@dataclass(frozen=True)
class Case:
    """decoder; exact: decode(encode(θ)) = θ for every θ in the box (no reduction)."""

    decoder: Decoder
    exact: bool = False


@lru_cache(maxsize=1)
def _push_dynamics():
    from embeddings import DynamicsNetwork, TrainingConfig, push_transitions

    data = push_transitions(push_space(), 256, seed=0)
    net = DynamicsNetwork(push_space(), hidden=(8,)).fit(data, training=TrainingConfig(epochs=2, batch_size=64))
    return net, data


def _vae() -> Case:
    from embeddings import VAE, TrainingConfig

    return Case(VAE(ParameterSpace.t6(), dim=2, hidden=8).fit(64, training=TrainingConfig(epochs=1, batch_size=32)))


def _autoencoder() -> Case:
    from embeddings import DynamicsAutoencoder, TrainingConfig

    net, data = _push_dynamics()
    ae = DynamicsAutoencoder(push_space(), dim=1, hidden=4)
    return Case(ae.fit(net, data, training=TrainingConfig(epochs=2, batch_size=64, seed=1)))


def _active_fitted() -> Case:
    from embeddings import ActiveSubspace

    net, data = _push_dynamics()
    return Case(ActiveSubspace.fit(push_space(), net, data, dim=1, rows=128))


def _active_basis() -> Case:
    from embeddings import ActiveSubspace

    basis, _ = np.linalg.qr(np.random.default_rng(0).standard_normal((15, 3)))
    return Case(ActiveSubspace(ParameterSpace.t6(), basis))


def _local() -> Case:
    from embeddings import LocalSubspace

    basis = 0.05 * np.linalg.qr(np.random.default_rng(1).standard_normal((15, 3)))[0]
    return Case(LocalSubspace(ParameterSpace.t6(), np.full(15, 0.4), basis, span=3.0))


IMPLEMENTATIONS = [
    pytest.param(lambda: Case(Identity(push_space()), exact=True), id="Identity-push"),
    pytest.param(lambda: Case(Identity(ParameterSpace.t6()), exact=True), id="Identity-t6"),
    pytest.param(lambda: Case(REMBO(ParameterSpace.t6(), dim=3, seed=0)), id="REMBO"),
    pytest.param(_vae, id="VAE"),
    pytest.param(_autoencoder, id="DynamicsAutoencoder"),
    pytest.param(_active_fitted, id="ActiveSubspace-fitted"),
    pytest.param(_active_basis, id="ActiveSubspace-basis"),
    pytest.param(_local, id="LocalSubspace"),
]
#: the config kinds IMPLEMENTATIONS covers; every registered kind must be among them
COVERED = {"identity", "rembo", "vae", "ae-dyn", "active", "local"}


@pytest.fixture(scope="module", params=IMPLEMENTATIONS)
def case(request) -> Case:
    return request.param()


def _latent(decoder: Decoder, n: int = 32) -> np.ndarray:
    """n points of the latent box: its two extreme corners, then scrambled Sobol points."""
    lo, hi = decoder.bounds[:, 0], decoder.bounds[:, 1]
    inner = qmc.scale(qmc.Sobol(decoder.dim, seed=0).random(n - 2), lo, hi)
    return np.vstack([lo, hi, inner])


def test_every_registered_kind_is_checked() -> None:
    assert set(registered_kinds()) <= COVERED, "add the new decoder kind to IMPLEMENTATIONS"


def test_declares_the_contract(case: Case) -> None:
    dec = case.decoder
    assert isinstance(dec, Decoder) and not type(dec).__abstractmethods__
    assert isinstance(dec.space, ParameterSpace) and isinstance(dec.dim, int) and 1 <= dec.dim <= dec.space.dim
    b = dec.bounds
    assert b.shape == (dec.dim, 2) and np.isfinite(b).all() and (b[:, 0] < b[:, 1]).all()
    assert json.loads(json.dumps(dec.config()))["kind"] in COVERED


def test_decode_maps_the_latent_box_inside_the_parameter_box(case: Case) -> None:
    dec = case.decoder
    z = _latent(dec)
    theta = dec.decode(z)
    assert theta.shape == (len(z), dec.space.dim) and np.isfinite(theta).all()
    assert (theta >= dec.space.lower).all() and (theta <= dec.space.upper).all()
    np.testing.assert_allclose(dec.decode(z[3]), theta[3], rtol=1e-6)    # one d vector -> one D vector
    np.testing.assert_array_equal(dec.decode(z), theta)                # deterministic


def test_decode_refuses_points_it_cannot_decode(case: Case) -> None:
    dec = case.decoder
    hi = dec.bounds[:, 1]
    for bad in (hi[None] + 1.0, np.zeros((2, dec.dim + 1)), np.full((1, dec.dim), np.nan)):
        with pytest.raises(EmbeddingError):
            dec.decode(bad)


def test_config_rebuilds_the_same_decoder(case: Case) -> None:
    dec = case.decoder
    config = json.loads(json.dumps(dec.config()))                      # as a journal or a belief stores it
    z = _latent(dec)
    for rebuilt in (decoder_from_config(config, dec.space), type(dec).from_config(config, dec.space)):
        assert type(rebuilt) is type(dec) and rebuilt.config() == dec.config()
        np.testing.assert_array_equal(rebuilt.decode(z), dec.decode(z))


def test_save_and_load_round_trip(case: Case, tmp_path) -> None:
    dec = case.decoder
    path = dec.save(tmp_path / "decoder.json")
    loaded = load_decoder(path, dec.space)
    assert json.loads(json.dumps(loaded.record())) == json.loads(json.dumps(dec.record()))
    z = _latent(dec)
    np.testing.assert_array_equal(loaded.decode(z), dec.decode(z))
    if isinstance(dec, EncodingDecoder):
        theta = dec.decode(z)
        np.testing.assert_array_equal(loaded.encode(theta), dec.encode(theta))   # restore() brings the encoder back


def test_encode_maps_theta_to_the_latent_space(case: Case) -> None:
    dec = case.decoder
    if not isinstance(dec, EncodingDecoder):
        pytest.skip(f"{type(dec).__name__} is not an EncodingDecoder")
    theta = dec.decode(_latent(dec))
    z = dec.encode(theta)
    assert z.shape == (len(theta), dec.dim) and np.isfinite(z).all()
    np.testing.assert_allclose(dec.encode(theta[3]), z[3], rtol=1e-6, atol=1e-12)
    if case.exact:
        np.testing.assert_allclose(dec.decode(z), theta, rtol=1e-12, atol=1e-12)


def test_a_trained_decoder_refuses_to_work_untrained(case: Case) -> None:
    from embeddings.trained import TrainedDecoder

    dec = case.decoder
    if not isinstance(dec, TrainedDecoder):
        pytest.skip("not a trained decoder")
    fresh = type(dec)(dec.space, **dec.options())
    for call in (lambda: fresh.decode(np.zeros((1, dec.dim))), fresh.config, lambda: fresh.bounds):
        with pytest.raises(EmbeddingError, match="not trained"):
            call()
