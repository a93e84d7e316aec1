"""Active-subspace decoder: a linear embedding along the directions of θ the dynamics respond to.

The learned dynamics network g(u, x) (unit θ ``u``, context ``x``, standardized output ``k``) is
differentiable, so the average outer product of its Jacobian over the training rows::

    C = (1/N) Σ_i J_iᵀ J_i,     J_i = ∂g(u_i, x_i) / ∂u   (k x D),   C (D x D)

says how strongly each direction of the unit box changes the predicted next state (Constantine
2015, active subspaces). Its top ``d`` eigenvectors ``W`` (D x d) span the directions worth
searching; the remaining D - d are those the dynamics barely see, and they stay at the box centre::

    u = clip(0.5 + W z, 0, 1),   z ∈ [-a, a],   a_j = 0.5 Σ_i |W_ij|   (the cube's extent along w_j)

Unlike REMBO's random A, W is chosen by the physics; unlike the autoencoders, it is linear, so a
grid in z is a grid along known directions and every decoded θ is a plain linear combination.
``explained`` reports the fraction of trace(C) the kept directions carry.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import torch

from embeddings.base import EncodingDecoder
from embeddings.dynamics import DynamicsNetwork
from embeddings.errors import EmbeddingError
from embeddings.registry import check_config, register_decoder, require_keys
from embeddings.transitions import Transitions
from physics.parameters import ParameterSpace

__all__ = ["ActiveSubspace"]


@register_decoder("active")
class ActiveSubspace(EncodingDecoder):
    """Linear decoder z (``n x d``) -> θ along the top-``d`` eigenvectors of the dynamics' sensitivity.

    Build it with :meth:`fit` (from a dynamics network and its transitions) or from a basis ``W``.
    """

    def __init__(self, space: ParameterSpace, basis: np.ndarray, *, explained: float | None = None) -> None:
        W = np.asarray(basis, dtype=float)
        if W.ndim != 2 or W.shape[0] != space.dim or not 1 <= W.shape[1] <= space.dim or not np.all(np.isfinite(W)):
            raise EmbeddingError(f"ActiveSubspace basis must be a finite ({space.dim}, d) array with 1 <= d <= "
                                 f"{space.dim}, got shape {W.shape}.")
        self.space, self.W = space, W
        self.explained = None if explained is None else float(explained)
        self._half = 0.5 * np.abs(W).sum(axis=0)

    @classmethod
    def fit(cls, space: ParameterSpace, dynamics: DynamicsNetwork, data: Transitions, *, dim: int = 5,
            rows: int = 4000, seed: int = 0) -> ActiveSubspace:
        """Eigenvectors of C over ``rows`` random training rows (all when fewer); see the module docstring."""
        if not isinstance(dim, (int, np.integer)) or not 1 <= dim <= space.dim:
            raise EmbeddingError(f"ActiveSubspace dim must be an integer in [1, {space.dim}], got {dim!r}.")
        pick = np.random.default_rng(seed).permutation(len(data))[:rows]
        u = torch.as_tensor(data.unit_theta(space)[pick], dtype=torch.float32, device="cpu").requires_grad_(True)
        x = torch.as_tensor(data.context[pick], dtype=torch.float32)
        out = dynamics.forward_unit(u, x)                      # (n, k), row i depends on u_i only
        grads = [torch.autograd.grad(out[:, j].sum(), u, retain_graph=True)[0].numpy().astype(float)
                 for j in range(out.shape[1])]                  # k arrays (n, D)
        J = np.stack(grads, axis=1)                             # (n, k, D)
        C = np.einsum("nkd,nke->de", J, J) / len(pick)
        values, vectors = np.linalg.eigh(C)
        order = np.argsort(values)[::-1]
        W = vectors[:, order[:dim]]
        W = W * np.sign(W[np.argmax(np.abs(W), axis=0), np.arange(dim)])   # a fixed sign per direction
        return cls(space, W, explained=float(values[order[:dim]].sum() / values.sum()))

    @classmethod
    def from_config(cls, config: Mapping[str, Any], space: ParameterSpace) -> ActiveSubspace:
        """The decoder whose ``config()`` equals ``config``."""
        require_keys(config, ("kind", "basis", "explained", "names", "lower", "upper"), kind="active")
        decoder = cls(space, np.asarray(config["basis"], dtype=float), explained=config["explained"])
        check_config(decoder, config)
        return decoder

    @property
    def dim(self) -> int:
        return self.W.shape[1]

    @property
    def bounds(self) -> np.ndarray:
        return np.column_stack([-self._half, self._half])

    def _decode_unit(self, z: np.ndarray) -> np.ndarray:
        return np.clip(0.5 + z @ self.W.T, 0.0, 1.0)

    def encode(self, theta: np.ndarray) -> np.ndarray:
        """z = Wᵀ (u - 0.5): the coordinates of θ along the kept directions (``n x D`` -> ``n x d``)."""
        return (self.space.to_unit(np.asarray(theta, dtype=float)) - 0.5) @ self.W

    def config(self) -> dict[str, Any]:
        return {"kind": "active", "basis": self.W.tolist(), "explained": self.explained,
                "names": list(self.space.names), "lower": self.space.lower.tolist(),
                "upper": self.space.upper.tolist()}

    def __repr__(self) -> str:
        share = "" if self.explained is None else f", explains {self.explained:.1%} of the sensitivity"
        return f"ActiveSubspace(dim={self.dim}{share})"
