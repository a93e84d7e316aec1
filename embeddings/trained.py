"""The contract of decoders that are trained: ``fit``, ``save``/``load``, and a configuration that
carries the trained weights.

A :class:`TrainedDecoder` decodes with a torch module ``decoder_net``: latent ``z`` (``n x d``)
-> ``sigmoid(decoder_net(z))`` = unit-cube θ (``n x D``), then the parameter box (see
:class:`~embeddings.base.Decoder`). Its ``config()`` holds the architecture, the latent box and the
decoding network's weights (:func:`~embeddings.networks.pack_weights`, with their sha256), so

* the journal's problem fingerprint changes when the weights change (a resumed run refuses a
  different model), and
* :func:`~embeddings.registry.decoder_from_config` rebuilds the decoder bit for bit from a saved
  belief or journal alone.

``save(path)`` writes JSON: ``{"decoder": config(), "extra": {...}, "history": [...]}`` where
``extra`` holds what training needs beyond decoding (an encoder's weights) and ``history`` the
loss per epoch; ``load(path, space)`` (or :func:`embeddings.load_decoder`) reads it back. A
decoder that has not been trained refuses to decode or to be fingerprinted.
"""
from __future__ import annotations

import abc
import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import torch
from torch import nn

from embeddings.base import Decoder
from embeddings.errors import EmbeddingError
from embeddings.networks import pack_weights, unpack_weights
from physics.parameters import ParameterSpace

__all__ = ["TrainedDecoder"]


class TrainedDecoder(Decoder):
    """Base class of decoders with trained torch networks; subclasses build the networks and ``fit``."""

    kind: str = ""
    decoder_net: nn.Module

    def __init__(self, space: ParameterSpace, dim: int) -> None:
        if not isinstance(dim, (int, np.integer)) or not 1 <= int(dim) <= space.dim:
            raise EmbeddingError(f"{type(self).__name__} dim must be an integer in [1, {space.dim}] "
                                 f"(the parameter count), got {dim!r}.")
        self.space = space
        self._dim = int(dim)
        self._bounds: np.ndarray | None = None
        self.history: list[float] = []

    # -- what subclasses define -------------------------------------------------------------
    @abc.abstractmethod
    def options(self) -> dict[str, Any]:
        """Architecture options (JSON-able) that rebuild the untrained networks: ``cls(space, **options)``."""

    def extra_state(self) -> dict[str, Any]:
        """What ``save`` keeps beyond decoding (e.g. an encoder's packed weights); default nothing."""
        return {}

    def load_extra_state(self, extra: Mapping[str, Any]) -> None:
        """Restore :meth:`extra_state` after ``load``; default nothing."""

    def restore(self, record: Mapping[str, Any]) -> None:
        """Restore the training state of a :meth:`record` read back by ``load_decoder``."""
        self.load_extra_state(record.get("extra", {}))
        self.history = [float(v) for v in record.get("history", [])]

    # -- the decoder contract -------------------------------------------------------------
    @property
    def trained(self) -> bool:
        """True once ``fit`` or ``load`` has set the weights and the latent box."""
        return self._bounds is not None

    def _require_trained(self) -> np.ndarray:
        if self._bounds is None:
            raise EmbeddingError(f"{type(self).__name__} is not trained: call fit(...) or "
                                 f"{type(self).__name__}.load(path, space) first.")
        return self._bounds

    @property
    def dim(self) -> int:
        return self._dim

    @property
    def bounds(self) -> np.ndarray:
        return self._require_trained().copy()

    def _decode_unit(self, z: np.ndarray) -> np.ndarray:
        self._require_trained()
        with torch.no_grad():
            out = torch.sigmoid(self.decoder_net(torch.as_tensor(z, dtype=torch.float32)))
        return out.numpy().astype(float)

    def config(self) -> dict[str, Any]:
        bounds = self._require_trained()
        return {"kind": self.kind, **self.options(), "bounds": bounds.tolist(),
                "names": list(self.space.names), "lower": self.space.lower.tolist(),
                "upper": self.space.upper.tolist(), "weights": pack_weights(self.decoder_net)}

    @classmethod
    def from_config(cls, config: Mapping[str, Any], space: ParameterSpace) -> TrainedDecoder:
        """The trained decoder whose ``config()`` equals ``config`` (weights checked against their sha256)."""
        from embeddings.registry import check_config, require_keys

        require_keys(config, ("kind", "bounds", "weights", "names", "lower", "upper"), kind=cls.kind)
        if list(config["names"]) != list(space.names) or not np.allclose(config["lower"], space.lower) \
                or not np.allclose(config["upper"], space.upper):
            raise EmbeddingError(f"this {cls.kind} decoder was trained on the parameters {list(config['names'])} with "
                                 f"another box than the space given ({list(space.names)}); load it on the space it "
                                 f"was trained on or train it again.")
        reserved = {"kind", "bounds", "weights", "names", "lower", "upper"}
        try:
            decoder = cls(space, **{k: v for k, v in config.items() if k not in reserved})
        except TypeError as exc:
            raise EmbeddingError(f"the saved {cls.kind} configuration has options this version does not "
                                 f"know: {exc}") from None
        unpack_weights(decoder.decoder_net, config["weights"])
        decoder._set_bounds(np.asarray(config["bounds"], dtype=float))
        check_config(decoder, config)
        return decoder

    def _set_bounds(self, bounds: np.ndarray) -> None:
        if bounds.shape != (self._dim, 2) or not np.all(np.isfinite(bounds)) or np.any(bounds[:, 1] <= bounds[:, 0]):
            raise EmbeddingError(f"a latent box must be a finite ({self._dim}, 2) array with lower < upper, "
                                 f"got {bounds.tolist()!r}.")
        self._bounds = bounds.astype(float)

    def fingerprint(self) -> str:
        """sha256 of the decoding network's weights (the part of ``config()`` that training sets)."""
        self._require_trained()
        return pack_weights(self.decoder_net)["sha256"]

    # -- files ---------------------------------------------------------------------------------
    def record(self) -> dict[str, Any]:
        """What ``save`` writes: the config with weights, the extra training state and the loss history."""
        return {"decoder": self.config(), "extra": self.extra_state(), "history": list(self.history)}

    @classmethod
    def load(cls, path: str | os.PathLike[str], space: ParameterSpace) -> TrainedDecoder:
        """The decoder saved at ``path`` on ``space``; raises :class:`EmbeddingError` if it is of another kind."""
        from embeddings.registry import load_decoder

        decoder = load_decoder(path, space)
        if not isinstance(decoder, cls):
            raise EmbeddingError(f"{path} holds a {type(decoder).__name__} decoder, not a {cls.__name__}; "
                                 f"use embeddings.load_decoder for any kind.")
        return decoder

    def __repr__(self) -> str:
        state = f"weights {self.fingerprint()[:12]}" if self.trained else "untrained"
        return f"{type(self).__name__}({self.options()}, {state})"

