"""A local decoder: a box of a few posterior standard deviations around a fitted θ̂, along the
directions the data pin.

After a global search and a local fit, the likelihood near θ̂ is narrow in the directions the data
pin and wide in the others. A grid over the whole prior box cannot resolve the narrow ones (a cell
of a 4096-point Sobol set in 15-D is tens of posterior widths across). This decoder spans ``d``
directions w_1 .. w_d of the unit box, each already scaled to one posterior standard deviation::

    u = clip(û + W z, 0, 1),    z ∈ [−span, span]^d,    θ = lower + (upper − lower) u

û the fit in the unit box, W (D x d) the scaled directions (the eigenvectors of the Fisher
information at θ̂ over the square roots of the posterior precisions, belief.local_belief). A regular
grid in z is then a grid at the data's resolution: 7 points on [−3, 3] put cells one standard
deviation apart. The other D − d directions stay at θ̂ in the decoder; the belief spreads them
(belief.spread.ComplementSpread).
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from embeddings.base import EncodingDecoder
from embeddings.errors import EmbeddingError
from embeddings.registry import check_config, register_decoder, require_keys
from physics.parameters import ParameterSpace

__all__ = ["LocalSubspace"]


@register_decoder("local")
class LocalSubspace(EncodingDecoder):
    """Linear decoder z (``n x d``) -> θ = lower + width ⊙ clip(û + W z, 0, 1) on [−span, span]^d."""

    def __init__(self, space: ParameterSpace, centre: np.ndarray, basis: np.ndarray, *, span: float = 3.0) -> None:
        u = np.asarray(centre, dtype=float)
        W = np.asarray(basis, dtype=float)
        if u.shape != (space.dim,) or not np.all(np.isfinite(u)) or np.any(u < -1e-9) or np.any(u > 1 + 1e-9):
            raise EmbeddingError(f"LocalSubspace centre must be a point of the unit box with {space.dim} values, "
                                 f"got shape {u.shape}.")
        if W.ndim != 2 or W.shape[0] != space.dim or not 1 <= W.shape[1] <= space.dim or not np.all(np.isfinite(W)) \
                or np.any(np.linalg.norm(W, axis=0) == 0):
            raise EmbeddingError(f"LocalSubspace basis must be a finite ({space.dim}, d) array of non-zero columns "
                                 f"with 1 <= d <= {space.dim}, got shape {W.shape}.")
        if not (np.isfinite(span) and span > 0):
            raise EmbeddingError(f"LocalSubspace span must be a positive number of standard deviations, got {span!r}.")
        self.space, self.centre, self.W, self.span = space, np.clip(u, 0.0, 1.0), W, float(span)

    @classmethod
    def from_config(cls, config: Mapping[str, Any], space: ParameterSpace) -> LocalSubspace:
        """The decoder whose ``config()`` equals ``config``."""
        require_keys(config, ("kind", "centre", "basis", "span", "names", "lower", "upper"), kind="local")
        decoder = cls(space, np.asarray(config["centre"], dtype=float), np.asarray(config["basis"], dtype=float),
                      span=float(config["span"]))
        check_config(decoder, config)
        return decoder

    @property
    def dim(self) -> int:
        return self.W.shape[1]

    @property
    def bounds(self) -> np.ndarray:
        return np.column_stack([np.full(self.dim, -self.span), np.full(self.dim, self.span)])

    def _decode_unit(self, z: np.ndarray) -> np.ndarray:
        return np.clip(self.centre + z @ self.W.T, 0.0, 1.0)

    def encode(self, theta: np.ndarray) -> np.ndarray:
        """z minimizing ||W z − (u − û)|| (least squares), clipped to the latent box: the coordinates of
        θ along the spanned directions (``n x D`` -> ``n x d``)."""
        u = self.space.to_unit(np.asarray(theta, dtype=float))
        z = np.linalg.lstsq(self.W, np.atleast_2d(u - self.centre).T, rcond=None)[0].T
        z = np.clip(z, -self.span, self.span)
        return z[0] if np.ndim(theta) == 1 else z

    def config(self) -> dict[str, Any]:
        return {"kind": "local", "centre": self.centre.tolist(), "basis": self.W.tolist(), "span": self.span,
                "names": list(self.space.names), "lower": self.space.lower.tolist(),
                "upper": self.space.upper.tolist()}

    def __repr__(self) -> str:
        return f"LocalSubspace(dim={self.dim}, span=±{self.span:g} sd)"
