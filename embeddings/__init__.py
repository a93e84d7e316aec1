"""Decoders from a low-dimensional latent box to the physical parameter vector θ.

``Identity`` (no reduction, the unit cube of the space) and ``REMBO`` (random linear embedding,
Wang et al. 2016). VAE and dynamics-aware autoencoders come later. embeddings depends on physics
only (parameter spaces), never on belief.
"""
from __future__ import annotations

from embeddings.base import Decoder
from embeddings.errors import EmbeddingError
from embeddings.identity import Identity
from embeddings.rembo import REMBO
from embeddings.registry import decoder_from_config, register_decoder

__all__ = ["Decoder", "EmbeddingError", "Identity", "REMBO", "decoder_from_config", "register_decoder"]
