"""Variational autoencoder over the parameter box (Zhu et al. 2018, Sec. III-C; Kingma & Welling 2014).

Trained on θ drawn uniformly from the box, in unit coordinates ``u = (θ - lower) / (upper - lower)``::

    encoder   u (D) -> hidden (400, ReLU) -> (mean, log variance) of q(α | u)   (d each)
    decoder   α (d) -> hidden (400, ReLU) -> sigmoid -> u' (D)
    loss      Σ_D (u - u')² / (2 s²)  +  KL(q(α | u) || N(0, I))      per row, s = ``recon_scale``

The decoder is used for search: the latent box is ``[-latent_scale, latent_scale]^d`` (the paper's
[-3, 3]^5 covers 99.7 % of the N(0, 1) prior per axis). It learns what the *parameter* samples
look like, not what the dynamics see: with a uniform prior on θ it keeps d directions of the box
and folds the rest towards the centre, which is why the paper's dynamics-aware autoencoder
(:mod:`embeddings.autoencoder`) does better.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import torch

from embeddings.base import EncodingDecoder
from embeddings.errors import EmbeddingError
from embeddings.networks import TrainingConfig, mlp, pack_weights, seeded, train, unpack_weights
from embeddings.registry import register_decoder
from embeddings.trained import TrainedDecoder
from physics.parameters import ParameterSpace

__all__ = ["VAE"]


@register_decoder("vae")
class VAE(TrainedDecoder, EncodingDecoder):
    """VAE decoder α ∈ [-latent_scale, latent_scale]^d -> θ; ``fit`` trains it on θ uniform in the box.

    ``dim``: latent d (paper: 5); ``hidden``: width of the one hidden layer (paper: 400);
    ``latent_scale``: half-width of the search box (paper: 3); ``recon_scale``: s of the Gaussian
    reconstruction likelihood in unit coordinates (smaller weighs reconstruction more than the prior).
    """

    kind = "vae"

    def __init__(self, space: ParameterSpace, *, dim: int = 5, hidden: int = 400, latent_scale: float = 3.0,
                 recon_scale: float = 0.1) -> None:
        super().__init__(space, dim)
        if not isinstance(hidden, (int, np.integer)) or hidden < 1:
            raise EmbeddingError(f"VAE hidden must be a positive integer (layer width), got {hidden!r}.")
        for name, value in (("latent_scale", latent_scale), ("recon_scale", recon_scale)):
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise EmbeddingError(f"VAE {name} must be a positive number, got {value!r}.")
        self.hidden, self.latent_scale, self.recon_scale = int(hidden), float(latent_scale), float(recon_scale)
        self._build(0)

    def _build(self, seed: int) -> None:
        """Fresh encoder and decoder with initial weights from ``seed``."""
        with seeded(seed):
            self.encoder_net = mlp([self.space.dim, self.hidden, 2 * self._dim])
            self.decoder_net = mlp([self._dim, self.hidden, self.space.dim])

    def options(self) -> dict[str, Any]:
        return {"dim": self._dim, "hidden": self.hidden, "latent_scale": self.latent_scale,
                "recon_scale": self.recon_scale}

    def extra_state(self) -> dict[str, Any]:
        return {"encoder": pack_weights(self.encoder_net)}

    def load_extra_state(self, extra: Mapping[str, Any]) -> None:
        if "encoder" in extra:
            unpack_weights(self.encoder_net, extra["encoder"])

    def fit(self, n_samples: int = 20000, *, training: TrainingConfig | None = None, progress: bool = False) -> VAE:
        """Train on ``n_samples`` θ drawn uniformly from the box with ``training.seed``; returns self."""
        training = training or TrainingConfig(epochs=100, batch_size=256, lr=1e-3)
        if not isinstance(n_samples, (int, np.integer)) or n_samples < 2:
            raise EmbeddingError(f"VAE.fit needs n_samples >= 2 parameter draws, got {n_samples!r}.")
        self._build(int(training.seed))
        rng = np.random.default_rng(int(training.seed))
        data = torch.as_tensor(rng.random((int(n_samples), self.space.dim)), dtype=torch.float32)
        params = list(self.encoder_net.parameters()) + list(self.decoder_net.parameters())

        def loss(rows: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
            u = data[rows]
            mean, log_var = self.encoder_net(u).chunk(2, dim=1)
            eps = torch.randn(mean.shape, generator=generator)
            alpha = mean + torch.exp(0.5 * log_var) * eps
            recon = torch.sigmoid(self.decoder_net(alpha))
            nll = ((u - recon) ** 2).sum(dim=1) / (2.0 * self.recon_scale ** 2)
            kl = 0.5 * (mean ** 2 + log_var.exp() - 1.0 - log_var).sum(dim=1)
            return (nll + kl).mean()

        self.history = train(params, loss, int(n_samples), training, progress=progress, desc="VAE")
        self._set_bounds(np.tile([-self.latent_scale, self.latent_scale], (self._dim, 1)))
        return self

    def encode(self, theta: np.ndarray) -> np.ndarray:
        """Posterior means of α for θ (``n x D`` -> ``n x d``; a ``D`` vector gives a ``d`` vector)."""
        self._require_trained()
        u = self.space.to_unit(np.asarray(theta, dtype=float))
        with torch.no_grad():
            mean = self.encoder_net(torch.as_tensor(np.atleast_2d(u), dtype=torch.float32)).chunk(2, dim=1)[0]
        out = mean.numpy().astype(float)
        return out[0] if np.ndim(theta) == 1 else out

