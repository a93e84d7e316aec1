"""The autoencoder trained through a frozen dynamics network (Zhu et al. 2018, Sec. III-D, Fig. 3b).

In unit coordinates ``u = (θ - lower) / (upper - lower)``::

    encoder   u (D) -> hidden (ReLU) -> α (d)
    decoder   α (d) -> hidden (ReLU) -> sigmoid -> u' (D)
    loss      mean over rows of || g(u', x) - (y - mean_y) / std_y ||²  / k  +  λ s 12 || u' - 1/2 ||² / D

where ``g`` is the frozen :class:`~embeddings.dynamics.DynamicsNetwork` (standardized output), x
the row's context and y the *simulated* next-state summary at the row's θ. The loss never asks
for u' = u: the autoencoder only has to keep what changes the dynamics, so d can be much smaller
than D when the dynamics depend on few combinations of θ (the push toy depends on m²μ alone).

The second term (λ = ``centre_weight``, 0 in the paper) is a weak prior toward the box centre.
Directions of θ the network cannot see leave the dynamics term flat, and without the prior the
decoder parks them anywhere, often on the box's faces, where a whole-trajectory error does see
them. s = ½ mean || g(u_π, x) - g(u, x) ||² / k, with π a random pairing of the rows, is the
θ-induced variance of the standardized prediction, and 12 || u' - ½ ||² / D is 1 for u' uniform in
the box; so λ is the prior's weight relative to what θ does to the dynamics, whatever the target's
scale. With λ well below 1 the seen directions follow the dynamics and the unseen ones decode to
nominal, as the active subspace's dropped directions do.

The search box is the bounding box of the encoded training θ, widened by ``margin`` of its width
on each side. Search then runs BO over a grid in that box and decodes with the decoder.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import torch

from embeddings.base import EncodingDecoder
from embeddings.dynamics import DynamicsNetwork
from embeddings.errors import EmbeddingError
from embeddings.networks import TrainingConfig, mlp, pack_weights, seeded, train, unpack_weights
from embeddings.registry import register_decoder
from embeddings.trained import TrainedDecoder
from embeddings.transitions import Transitions
from physics.parameters import ParameterSpace

__all__ = ["DynamicsAutoencoder"]


@register_decoder("ae-dyn")
class DynamicsAutoencoder(TrainedDecoder, EncodingDecoder):
    """Decoder α -> θ of an autoencoder trained on the dynamics loss (module docstring).

    ``dim``: latent d (paper, T6: 5; push toy: 1); ``hidden``: width of the encoder's and the
    decoder's hidden layer (paper, T6: 10; push toy: 32); ``margin``: widening of the latent box;
    ``centre_weight``: λ of the prior toward the box centre (module docstring).
    """

    kind = "ae-dyn"

    def __init__(self, space: ParameterSpace, *, dim: int = 5, hidden: int = 10, margin: float = 0.05,
                 centre_weight: float = 0.0) -> None:
        super().__init__(space, dim)
        if not isinstance(hidden, (int, np.integer)) or hidden < 1:
            raise EmbeddingError(f"DynamicsAutoencoder hidden must be a positive integer, got {hidden!r}.")
        if not (isinstance(margin, (int, float)) and np.isfinite(margin) and margin >= 0):
            raise EmbeddingError(f"DynamicsAutoencoder margin must be a number >= 0, got {margin!r}.")
        if not (isinstance(centre_weight, (int, float)) and np.isfinite(centre_weight) and centre_weight >= 0):
            raise EmbeddingError(f"DynamicsAutoencoder centre_weight must be a number >= 0, got {centre_weight!r}.")
        self.hidden, self.margin, self.centre_weight = int(hidden), float(margin), float(centre_weight)
        self._build(0)

    def _build(self, seed: int) -> None:
        """Fresh encoder and decoder with initial weights from ``seed``."""
        with seeded(seed):
            self.encoder_net = mlp([self.space.dim, self.hidden, self._dim])
            self.decoder_net = mlp([self._dim, self.hidden, self.space.dim])

    def options(self) -> dict[str, Any]:
        options = {"dim": self._dim, "hidden": self.hidden, "margin": self.margin}
        if self.centre_weight:          # absent when 0, so files of the paper's autoencoder keep their fingerprint
            options["centre_weight"] = self.centre_weight
        return options

    def extra_state(self) -> dict[str, Any]:
        return {"encoder": pack_weights(self.encoder_net)}

    def load_extra_state(self, extra: Mapping[str, Any]) -> None:
        if "encoder" in extra:
            unpack_weights(self.encoder_net, extra["encoder"])

    def fit(self, dynamics: DynamicsNetwork, data: Transitions, *, training: TrainingConfig | None = None,
            progress: bool = False) -> DynamicsAutoencoder:
        """Train encoder and decoder through the frozen ``dynamics`` on ``data``; set the latent box; returns self."""
        training = training or TrainingConfig(epochs=100, batch_size=256, lr=3e-3)
        if dynamics.space.names != self.space.names:
            raise EmbeddingError(f"the dynamics network was trained on {list(dynamics.space.names)}, this "
                                 f"autoencoder decodes to {list(self.space.names)}; use the same space.")
        if tuple(data.context_names) != tuple(dynamics.context_names):
            raise EmbeddingError("the transitions' context differs from the one the dynamics network was trained "
                                 f"on ({list(data.context_names)[:4]}... vs {list(dynamics.context_names)[:4]}...).")
        self._build(training.seed)
        u = torch.as_tensor(data.unit_theta(self.space), dtype=torch.float32)
        x = torch.as_tensor(data.context, dtype=torch.float32)
        y = dynamics.standardize(torch.as_tensor(data.target, dtype=torch.float32))
        net = dynamics.forward_unit
        frozen = [p for p in dynamics.net.parameters() if p.requires_grad]  # type: ignore[union-attr]
        weight = self.centre_weight * 12.0 * dynamics.theta_sensitivity(u, x, seed=training.seed)

        def loss(rows: torch.Tensor, _: torch.Generator) -> torch.Tensor:
            u_prime = torch.sigmoid(self.decoder_net(self.encoder_net(u[rows])))
            prior = weight * ((u_prime - 0.5) ** 2).mean() if weight else 0.0
            return ((net(u_prime, x[rows]) - y[rows]) ** 2).mean() + prior

        params = list(self.encoder_net.parameters()) + list(self.decoder_net.parameters())
        for p in frozen:                # the dynamics network stays as it was; only the autoencoder learns
            p.requires_grad_(False)
        try:
            self.history = train(params, loss, len(data), training, progress=progress, desc="dynamics autoencoder")
        finally:
            for p in frozen:
                p.requires_grad_(True)
        alpha = self.encode(np.unique(data.theta, axis=0), check=False)
        lo, hi = alpha.min(axis=0), alpha.max(axis=0)
        if np.any(hi - lo <= 1e-9):
            raise EmbeddingError("the trained encoder maps all training θ to one point on some latent axis; "
                                 "train longer, with another seed, or with a smaller dim.")
        pad = self.margin * (hi - lo)
        self._set_bounds(np.column_stack([lo - pad, hi + pad]))
        return self

    def encode(self, theta: np.ndarray, *, check: bool = True) -> np.ndarray:
        """α = encoder(θ): ``n x D`` -> ``n x d`` (a ``D`` vector gives a ``d`` vector)."""
        if check:
            self._require_trained()
        u = self.space.to_unit(np.atleast_2d(np.asarray(theta, dtype=float)))
        with torch.no_grad():
            out = self.encoder_net(torch.as_tensor(u, dtype=torch.float32)).numpy().astype(float)
        return out[0] if np.ndim(theta) == 1 else out
