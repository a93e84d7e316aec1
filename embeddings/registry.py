"""Rebuild a decoder from its saved configuration (``Decoder.config()``), so that a saved belief
or journal reloads with exactly the decoder that produced it.

Each decoder kind registers a builder ``(config, space) -> Decoder``; the rebuilt decoder's
``config()`` must equal the saved one (a REMBO matrix redrawn from its seed, for instance), else
:class:`EmbeddingError` says what differs.
"""
from __future__ import annotations

from typing import Any, Callable

from embeddings.base import Decoder
from embeddings.errors import EmbeddingError
from embeddings.identity import Identity
from embeddings.rembo import REMBO
from physics.parameters import ParameterSpace

__all__ = ["register_decoder", "decoder_from_config"]

_BUILDERS: dict[str, Callable[[dict[str, Any], ParameterSpace], Decoder]] = {}


def register_decoder(kind: str, builder: Callable[[dict[str, Any], ParameterSpace], Decoder]) -> None:
    """Make ``decoder_from_config`` rebuild configs of ``kind`` with ``builder(config, space)``."""
    _BUILDERS[str(kind)] = builder


register_decoder("identity", lambda cfg, space: Identity(space))
register_decoder("rembo", lambda cfg, space: REMBO(space, dim=int(cfg["dim"]), seed=int(cfg["seed"]),
                                                  box_scale=float(cfg["box_scale"])))


def decoder_from_config(config: dict[str, Any], space: ParameterSpace) -> Decoder:
    """The decoder whose ``config()`` equals ``config``, on parameter space ``space``."""
    kind = config.get("kind") if isinstance(config, dict) else None
    if kind not in _BUILDERS:
        raise EmbeddingError(f"unknown decoder kind {kind!r} in the saved configuration; known kinds: "
                             f"{sorted(_BUILDERS)} (register others with embeddings.register_decoder).")
    decoder = _BUILDERS[kind](config, space)
    rebuilt = decoder.config()
    if rebuilt != config:
        keys = sorted(k for k in set(rebuilt) | set(config) if rebuilt.get(k) != config.get(k))
        raise EmbeddingError(f"the rebuilt {kind} decoder differs from the saved configuration in {keys}; "
                             "the file was written on another parameter space or by another version.")
    return decoder
