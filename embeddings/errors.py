"""Typed errors of the embeddings package (decoders from a latent box to θ)."""
from __future__ import annotations

from physics.errors import TensegridError

__all__ = ["EmbeddingError"]


class EmbeddingError(TensegridError, ValueError):
    """A decoder was given an invalid option or latent points of the wrong shape or outside its box."""
