"""The identity decoder: the latent box is the unit cube of the parameter space, θ = lower + z (upper - lower)."""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from embeddings.base import EncodingDecoder
from embeddings.registry import check_config, register_decoder, require_keys
from physics.parameters import ParameterSpace

__all__ = ["Identity"]


@register_decoder("identity")
class Identity(EncodingDecoder):
    """z ∈ [0, 1]^D  ->  θ = lower + z ⊙ (upper - lower), ``n x D`` -> ``n x D`` (no reduction; d = D)."""

    def __init__(self, space: ParameterSpace) -> None:
        self.space = space

    @classmethod
    def from_config(cls, config: Mapping[str, Any], space: ParameterSpace) -> Identity:
        """The Identity on ``space`` whose ``config()`` equals ``config`` (names and bounds must match ``space``).

        Raises :class:`~embeddings.errors.EmbeddingError` naming missing or differing keys.
        """
        require_keys(config, ("kind", "names", "lower", "upper"), kind="identity")
        decoder = cls(space)
        check_config(decoder, config)
        return decoder

    @property
    def dim(self) -> int:
        return self.space.dim

    @property
    def bounds(self) -> np.ndarray:
        return np.tile([0.0, 1.0], (self.space.dim, 1))

    def _decode_unit(self, z: np.ndarray) -> np.ndarray:
        return z

    def encode(self, theta: np.ndarray) -> np.ndarray:
        """z = (θ - lower) / (upper - lower); ``n x D`` or ``D``."""
        return self.space.to_unit(theta)

    def config(self) -> dict[str, Any]:
        return {"kind": "identity", "names": list(self.space.names),
                "lower": self.space.lower.tolist(), "upper": self.space.upper.tolist()}
