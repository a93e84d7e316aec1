"""Decoders from a low-dimensional latent box to the physical parameter vector θ.

``Identity`` (no reduction, the unit cube of the space) and ``REMBO`` (random linear embedding,
Wang et al. 2016). VAE and dynamics-aware autoencoders come later. ``decoder_from_config`` rebuilds a
decoder from its saved ``config()`` (the registry of kinds, :mod:`embeddings.registry`). embeddings
depends on physics only (parameter spaces), never on belief.
"""
from __future__ import annotations

from embeddings.base import Decoder
from embeddings.errors import EmbeddingError
from embeddings.identity import Identity
from embeddings.rembo import REMBO
from embeddings.registry import decoder_from_config, register_decoder, registered_kinds

__all__ = ["Decoder", "EmbeddingError", "Identity", "REMBO", "decoder_from_config", "register_decoder",
           "registered_kinds"]
