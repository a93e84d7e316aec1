"""The decoder protocol: a map from a low-dimensional latent box to the parameter box.

A decoder has ``space`` (the :class:`~physics.parameters.ParameterSpace`, dimension ``D``),
``dim`` (the latent dimension ``d``), ``bounds`` (``d x 2`` array of the latent box
``[lower, upper]`` per latent coordinate) and ``decode(z)`` mapping ``n x d`` latent points to
``n x D`` parameter vectors that always lie inside ``[space.lower, space.upper]``. ``config()``
returns a JSON-able description used to fingerprint an identification problem (journal);
``save(path)`` writes it as JSON and :func:`embeddings.load_decoder` rebuilds the decoder from it.
"""
from __future__ import annotations

import abc
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from embeddings.errors import EmbeddingError
from physics.parameters import ParameterSpace

__all__ = ["Decoder", "write_json"]


def write_json(path: "str | os.PathLike[str]", record: Any) -> Path:
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

    def decode(self, z: "np.ndarray") -> np.ndarray:
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

    def save(self, path: "str | os.PathLike[str]") -> Path:
        """Write :meth:`record` as JSON (atomically); ``embeddings.load_decoder(path, space)`` reads it back."""
        return write_json(path, self.record())

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.config()})"
