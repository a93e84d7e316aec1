"""The decoder protocol: a map from a low-dimensional latent box to the parameter box.

A decoder has ``space`` (the :class:`~physics.parameters.ParameterSpace`, dimension ``D``),
``dim`` (the latent dimension ``d``), ``bounds`` (``d x 2`` array of the latent box
``[lower, upper]`` per latent coordinate) and ``decode(z)`` mapping ``n x d`` latent points to
``n x D`` parameter vectors that always lie inside ``[space.lower, space.upper]``. ``config()``
returns a JSON-able description used to fingerprint an identification problem (journal), and
the classmethod ``from_config(config, space)`` rebuilds the decoder from it; ``save(path)`` writes
:meth:`Decoder.record` as JSON and :func:`embeddings.load_decoder` reads it back (``from_config``,
then :meth:`Decoder.restore` for state beyond the configuration, e.g. a trained encoder).

:class:`EncodingDecoder` is the optional part of the contract: decoders that also map θ back to
the latent box (``encode``), which a hand-over of evaluations to another latent space needs
(belief.handoff). Identity, ActiveSubspace and the trained autoencoders have it; REMBO does not.
"""
from __future__ import annotations

import abc
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from embeddings.errors import EmbeddingError
from physics.parameters import ParameterSpace

__all__ = ["Decoder", "EncodingDecoder", "write_json"]

_Self = TypeVar("_Self", bound="Decoder")


def write_json(path: str | os.PathLike[str], record: Any) -> Path:
    """Write ``record`` as JSON through a temporary file, so a killed write leaves no half file."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(out.suffix + ".tmp")
    tmp.write_text(json.dumps(record))
    tmp.replace(out)
    return out


class Decoder(abc.ABC):
    """Abstract decoder z (``n x d``, inside ``bounds``) -> θ (``n x D``, inside the parameter box)."""

    space: ParameterSpace

    @property
    @abc.abstractmethod
    def dim(self) -> int:
        """Latent dimension d."""

    @property
    @abc.abstractmethod
    def bounds(self) -> np.ndarray:
        """Latent box, shape ``d x 2`` (column 0 lower, column 1 upper)."""

    @abc.abstractmethod
    def _decode_unit(self, z: np.ndarray) -> np.ndarray:
        """Validated latent points ``n x d`` -> unit-cube parameters ``n x D`` in [0, 1]."""

    @abc.abstractmethod
    def config(self) -> dict[str, Any]:
        """JSON-able description (kind and options) that identifies this decoder exactly."""

    @classmethod
    @abc.abstractmethod
    def from_config(cls: type[_Self], config: Mapping[str, Any], space: ParameterSpace) -> _Self:
        """The decoder on ``space`` whose ``config()`` equals ``config`` (EmbeddingError otherwise)."""

    def decode(self, z: np.ndarray) -> np.ndarray:
        """θ = decoder(z): ``n x d`` -> ``n x D`` (a single ``d`` vector gives a ``D`` vector).

        Raises :class:`EmbeddingError` for a wrong shape, NaN, or points outside ``bounds``.
        """
        arr = np.asarray(z, dtype=float)
        single = arr.ndim == 1
        arr2 = np.atleast_2d(arr)
        if arr2.ndim != 2 or arr2.shape[1] != self.dim:
            raise EmbeddingError(
                f"{type(self).__name__}.decode expects latent points of shape (n, {self.dim}) or "
                f"({self.dim},), got {arr.shape}."
            )
        if not np.all(np.isfinite(arr2)):
            raise EmbeddingError(f"{type(self).__name__}.decode got NaN or infinite latent coordinates.")
        lo, hi = self.bounds[:, 0], self.bounds[:, 1]
        tol = 1e-9 * (hi - lo)
        if np.any(arr2 < lo - tol) or np.any(arr2 > hi + tol):
            raise EmbeddingError(
                f"{type(self).__name__}.decode: latent points must lie in the box {self.bounds.tolist()}, "
                f"got values in [{arr2.min()!r}, {arr2.max()!r}]; clip them to decoder.bounds."
            )
        u = np.clip(self._decode_unit(np.clip(arr2, lo, hi)), 0.0, 1.0)
        theta = self.space.lower + u * (self.space.upper - self.space.lower)
        return theta[0] if single else theta

    def record(self) -> dict[str, Any]:
        """What :meth:`save` writes: ``{"decoder": config()}`` (trained decoders add their training state)."""
        return {"decoder": self.config()}

    def restore(self, record: Mapping[str, Any]) -> None:  # noqa: B027 (an optional hook, not abstract)
        """Restore what :meth:`record` holds beyond ``config()`` after a load; nothing by default."""

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`record` as JSON (atomically); ``embeddings.load_decoder(path, space)`` reads it back."""
        return write_json(path, self.record())

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.config()})"


class EncodingDecoder(Decoder):
    """A decoder that also encodes: θ (``n x D`` or ``D``) -> z (``n x d`` or ``d``).

    For a decoder without reduction (Identity) decode(encode(θ)) = θ; for a reducing one, encode
    gives the latent point whose decoding is near θ (a projection, or an encoder network's mean).
    """

    @abc.abstractmethod
    def encode(self, theta: np.ndarray) -> np.ndarray:
        """z for θ: ``n x D`` -> ``n x d`` (a single ``D`` vector gives a ``d`` vector)."""
