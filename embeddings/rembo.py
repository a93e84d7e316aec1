"""REMBO random embedding (Wang et al. 2016, "Bayesian optimization in a billion dimensions via
random embeddings", JAIR 55, Algorithm 2 and Sec. 4).

A matrix ``A`` of shape ``D x d`` with i.i.d. N(0, 1) entries (drawn from ``seed``) embeds the
latent box ``Z = [-sqrt(d), sqrt(d)]^d`` (Wang et al., Sec. 4.3) into the normalized parameter box
``X = [-1, 1]^D``::

    y = A z                        (D,)  may leave X
    x = clip(y, -1, 1)             projection p_X onto the nearest boundary point of X (Euclidean)
    θ = lower + (x + 1) / 2 ⊙ (upper - lower)

Clipping each coordinate independently is exactly the Euclidean projection onto a box.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from embeddings.base import Decoder
from embeddings.errors import EmbeddingError
from embeddings.registry import check_config, register_decoder, require_keys
from physics.parameters import ParameterSpace

__all__ = ["REMBO"]


@register_decoder("rembo")
class REMBO(Decoder):
    """Random linear embedding z (``n x d``) -> θ (``n x D``) with box projection; see module docstring.

    ``dim``: latent dimension d (1 <= d <= D); ``seed``: draws A ~ N(0, 1)^{D x d};
    ``box_scale``: half-width of the latent box, default sqrt(d) (Wang et al. 2016).
    """

    def __init__(self, space: ParameterSpace, *, dim: int, seed: int, box_scale: float | None = None) -> None:
        if not isinstance(dim, (int, np.integer)) or not 1 <= int(dim) <= space.dim:
            raise EmbeddingError(
                f"REMBO dim must be an integer in [1, {space.dim}] (the parameter count), got {dim!r}."
            )
        if not isinstance(seed, (int, np.integer)):
            raise EmbeddingError(f"REMBO seed must be an integer, got {seed!r}; the matrix A is drawn from it.")
        scale = float(np.sqrt(dim)) if box_scale is None else float(box_scale)
        if not (np.isfinite(scale) and scale > 0):
            raise EmbeddingError(f"REMBO box_scale must be a positive number, got {box_scale!r}.")
        self.space = space
        self._dim = int(dim)
        self.seed = int(seed)
        self.box_scale = scale
        #: the random matrix A, shape ``D x d``
        self.A = np.random.default_rng(self.seed).standard_normal((space.dim, self._dim))

    @classmethod
    def from_config(cls, config: Mapping[str, Any], space: ParameterSpace) -> REMBO:
        """The REMBO on ``space`` whose ``config()`` equals ``config``: A is redrawn from the saved ``seed``.

        The rebuilt configuration (d, seed, box_scale, names and bounds of ``space``) must equal
        the saved one, else :class:`EmbeddingError` names the differing keys.
        """
        require_keys(config, ("kind", "dim", "seed", "box_scale", "names", "lower", "upper"), kind="rembo")
        decoder = cls(space, dim=config["dim"], seed=config["seed"], box_scale=config["box_scale"])
        check_config(decoder, config)
        return decoder

    @property
    def dim(self) -> int:
        return self._dim

    @property
    def bounds(self) -> np.ndarray:
        return np.tile([-self.box_scale, self.box_scale], (self._dim, 1))

    def _decode_unit(self, z: np.ndarray) -> np.ndarray:
        x = np.clip(z @ self.A.T, -1.0, 1.0)
        return 0.5 * (x + 1.0)

    def config(self) -> dict[str, Any]:
        return {"kind": "rembo", "dim": self._dim, "seed": self.seed, "box_scale": self.box_scale,
                "names": list(self.space.names), "lower": self.space.lower.tolist(),
                "upper": self.space.upper.tolist()}
