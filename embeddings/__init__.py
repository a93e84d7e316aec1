"""Decoders from a low-dimensional latent box to the physical parameter vector θ.

``Identity`` (no reduction, the unit cube of the space), ``REMBO`` (random linear embedding,
Wang et al. 2016), and the trained decoders (fit/save/load, weights in their configuration):
``VAE`` (trained on θ from the box) and ``DynamicsAutoencoder`` (trained through a learned
``DynamicsNetwork`` on simulated ``Transitions``, Zhu et al. 2018), ``ActiveSubspace`` (a
linear embedding along the directions the learned dynamics are most sensitive to), and
``LocalSubspace`` (a box of a few posterior sds around a fit, along the directions the data
pin). ``decoder_from_config`` rebuilds a decoder from its saved ``config()`` and ``load_decoder``
from a file written by ``decoder.save`` (the registry of kinds, :mod:`embeddings.registry`). embeddings depends on
physics only (parameter spaces, simulation of training data), never on belief.

The torch-based classes are imported on first use, so ``import embeddings`` stays light.
"""
from __future__ import annotations

import importlib
from typing import Any

from embeddings.base import Decoder, EncodingDecoder
from embeddings.errors import EmbeddingError
from embeddings.identity import Identity
from embeddings.registry import decoder_from_config, load_decoder, register_decoder, registered_kinds
from embeddings.rembo import REMBO

_LAZY = {"VAE": "embeddings.vae", "ActiveSubspace": "embeddings.active", "LocalSubspace": "embeddings.local",
         "DynamicsAutoencoder": "embeddings.autoencoder", "DynamicsNetwork": "embeddings.dynamics",
         "Transitions": "embeddings.transitions",
         "push_transitions": "embeddings.transitions", "TrainingConfig": "embeddings.networks",
         "T6DataConfig": "embeddings.t6_data", "t6_transitions": "embeddings.t6_data"}

__all__ = ["Decoder", "EncodingDecoder", "EmbeddingError", "Identity", "REMBO", "decoder_from_config", "load_decoder",
           "register_decoder", "registered_kinds", *_LAZY]


def __getattr__(name: str) -> Any:
    """Import a torch-based public name's module on first access (PEP 562)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'embeddings' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
