"""decoder_from_config rebuilds Identity and REMBO exactly from their saved configs, and refuses the rest."""
from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest

from embeddings import REMBO, Decoder, EmbeddingError, Identity, decoder_from_config, register_decoder, registry
from embeddings import registered_kinds
from physics.parameters import Parameter, ParameterSpace

SPACE = ParameterSpace.t6()


def _other_space(**change: Any) -> ParameterSpace:
    return ParameterSpace(tuple(Parameter(**{**{k: getattr(p, k) for k in ("name", "unit", "nominal", "lower",
                                                                            "upper")}, **change})
                                if j == 0 else p for j, p in enumerate(SPACE.parameters)))


@pytest.mark.parametrize("make", [lambda: Identity(SPACE), lambda: REMBO(SPACE, dim=2, seed=4),
                                  lambda: REMBO(SPACE, dim=5, seed=123, box_scale=1.5)])
def test_config_round_trip_rebuilds_the_same_decoder(make) -> None:
    dec = make()
    saved = json.loads(json.dumps(dec.config()))                    # as a file stores it
    again = decoder_from_config(saved, SPACE)
    assert type(again) is type(dec) and again.config() == dec.config()
    assert type(dec).from_config(saved, SPACE).config() == dec.config()
    z = dec.bounds[:, 0] + np.random.default_rng(0).random((20, dec.dim)) * np.ptp(dec.bounds, axis=1)
    assert np.array_equal(again.decode(z), dec.decode(z))
    if isinstance(dec, REMBO):
        assert np.array_equal(again.A, dec.A)


def test_identity_and_rembo_are_registered() -> None:
    assert {"identity", "rembo", "vae", "ae-dyn"} <= set(registered_kinds())


def test_unknown_kind_names_the_known_kinds() -> None:
    with pytest.raises(EmbeddingError, match=r"unknown decoder kind 'pca'.*known kinds: \[.*'identity'.*'rembo'.*'vae'"):
        decoder_from_config({"kind": "pca"}, SPACE)
    with pytest.raises(EmbeddingError, match="unknown decoder kind None"):
        decoder_from_config(["rembo"], SPACE)                      # type: ignore[arg-type]


def test_rembo_config_mismatch_is_refused() -> None:
    cfg = REMBO(SPACE, dim=3, seed=2).config()
    with pytest.raises(EmbeddingError, match=r"differs from the saved configuration in \['lower'\]"):
        decoder_from_config(cfg, _other_space(lower=float(SPACE.lower[0]) * 0.5))
    with pytest.raises(EmbeddingError, match=r"differs from the saved configuration in \['names'\]"):
        decoder_from_config(cfg, _other_space(name="rho"))
    with pytest.raises(EmbeddingError, match="REMBO dim must be an integer"):
        decoder_from_config({**cfg, "dim": 3.5}, SPACE)
    with pytest.raises(EmbeddingError, match=r"in \['A_sha'\]"):
        REMBO.from_config({**cfg, "A_sha": "0"}, SPACE)
    with pytest.raises(EmbeddingError, match=r"rembo decoder configuration lacks \['seed'\]"):
        decoder_from_config({k: v for k, v in cfg.items() if k != "seed"}, SPACE)
    with pytest.raises(EmbeddingError, match="seed must be an integer"):
        decoder_from_config({**cfg, "seed": 2.5}, SPACE)


def test_identity_config_mismatch_is_refused() -> None:
    cfg = Identity(SPACE).config()
    with pytest.raises(EmbeddingError, match=r"identity decoder differs .* in \['upper'\]"):
        decoder_from_config(cfg, _other_space(upper=float(SPACE.upper[0]) * 2))
    with pytest.raises(EmbeddingError, match="needs a physics ParameterSpace"):
        decoder_from_config(cfg, list(SPACE.names))                 # type: ignore[arg-type]


class _Half(Decoder):
    """θ from a 1-D latent on [0, 1] placed on the diagonal of the unit cube (a toy registered decoder)."""

    def __init__(self, space: ParameterSpace) -> None:
        self.space = space

    dim = 1

    @property
    def bounds(self) -> np.ndarray:
        return np.array([[0.0, 1.0]])

    def _decode_unit(self, z: np.ndarray) -> np.ndarray:
        return np.repeat(z, self.space.dim, axis=1)

    def config(self) -> dict[str, Any]:
        return {"kind": "half"}

    @classmethod
    def from_config(cls, config: dict[str, Any], space: ParameterSpace) -> "_Half":
        return cls(space)


def test_register_decoder_adds_kinds_and_guards_them(monkeypatch) -> None:
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    assert register_decoder("half")(_Half) is _Half
    assert register_decoder("half")(_Half) is _Half                 # the same class again: no-op
    assert isinstance(decoder_from_config({"kind": "half"}, SPACE), _Half)
    with pytest.raises(EmbeddingError, match="decoder kind 'rembo' is already registered to REMBO"):
        register_decoder("rembo")(_Half)
    with pytest.raises(EmbeddingError, match="decorates a Decoder subclass"):
        register_decoder("thing")(dict)

    class Unbuildable(Decoder):      # from_config (and the rest of the contract) left abstract
        pass

    with pytest.raises(EmbeddingError, match=r"leaves \[.*'from_config'.*\] of the Decoder contract abstract"):
        register_decoder("unbuildable")(Unbuildable)
    with pytest.raises(EmbeddingError, match="non-empty string kind"):
        register_decoder("")
