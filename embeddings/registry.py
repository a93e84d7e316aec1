"""Rebuild a decoder from its saved configuration (``Decoder.config()``), so that a saved belief
or journal reloads with exactly the decoder that produced it.

The registry maps a configuration's ``kind`` (e.g. "identity", "rembo") to a decoder class with a
classmethod ``from_config(config, space) -> Decoder``; classes register themselves with the
decorator ``@register_decoder("kind")`` when their module is imported (importing ``embeddings``
registers Identity and REMBO). :func:`decoder_from_config` dispatches on ``kind`` and then checks
that the rebuilt decoder's ``config()`` equals the saved one (compared as JSON, the form in which
configurations are stored), so a file written on another parameter space, or by a decoder whose
options changed meaning, is refused instead of silently decoding to other θ.
"""
from __future__ import annotations

import importlib
import json
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

from embeddings.base import Decoder
from embeddings.errors import EmbeddingError
from physics.parameters import ParameterSpace

__all__ = ["register_decoder", "decoder_from_config", "load_decoder", "registered_kinds", "require_keys",
           "check_config"]

_D = TypeVar("_D", bound=type[Decoder])

_REGISTRY: dict[str, type[Decoder]] = {}
#: built-in kinds whose modules import torch: loaded when a configuration names them
_BUILT_IN = {"vae": "embeddings.vae", "ae-dyn": "embeddings.autoencoder", "active": "embeddings.active",
             "local": "embeddings.local"}


def register_decoder(kind: str) -> Callable[[_D], _D]:
    """Class decorator: ``decoder_from_config`` rebuilds configurations of ``kind`` with ``cls.from_config``.

    The class must be a concrete :class:`Decoder` (``from_config(config, space)`` is part of that
    contract). Registering another class under a taken kind raises :class:`EmbeddingError` (registering the
    same class again is a no-op).
    """
    if not isinstance(kind, str) or not kind:
        raise EmbeddingError(f"register_decoder needs a non-empty string kind (the 'kind' of config()), got {kind!r}.")

    def decorate(cls: _D) -> _D:
        if not (isinstance(cls, type) and issubclass(cls, Decoder)):
            raise EmbeddingError(f"register_decoder({kind!r}) decorates a Decoder subclass, got {cls!r}.")
        if cls.__abstractmethods__:
            raise EmbeddingError(f"register_decoder({kind!r}): {cls.__qualname__} leaves "
                                 f"{sorted(cls.__abstractmethods__)} of the Decoder contract abstract; define them "
                                 "(from_config(config, space) rebuilds a saved decoder).")
        known = _REGISTRY.get(kind)
        if known is not None and known is not cls:
            raise EmbeddingError(f"decoder kind {kind!r} is already registered to {known.__qualname__}; "
                                 f"choose another kind for {cls.__qualname__}.")
        _REGISTRY[kind] = cls
        return cls

    return decorate


def registered_kinds() -> tuple[str, ...]:
    """The decoder kinds :func:`decoder_from_config` knows, sorted."""
    return tuple(sorted(set(_REGISTRY) | set(_BUILT_IN)))


def require_keys(config: Mapping[str, Any], keys: Sequence[str], *, kind: str) -> None:
    """Raise :class:`EmbeddingError` naming the ``keys`` missing from a saved ``kind`` configuration."""
    if not isinstance(config, Mapping):
        raise EmbeddingError(f"a {kind} decoder configuration must be a dict (Decoder.config()), "
                             f"got {type(config).__name__}.")
    missing = [k for k in keys if k not in config]
    if missing:
        raise EmbeddingError(f"the saved {kind} decoder configuration lacks {missing} (has {sorted(config)}); "
                             f"save it with Decoder.config().")


def _as_json(value: Any) -> Any:
    return json.loads(json.dumps(value))


def check_config(decoder: Decoder, config: Mapping[str, Any]) -> None:
    """Raise :class:`EmbeddingError` unless ``decoder.config()`` equals ``config`` (compared as JSON).

    The message names the differing keys with the saved and the rebuilt values.
    """
    try:
        saved = _as_json(dict(config))
    except (TypeError, ValueError) as exc:
        raise EmbeddingError(f"a decoder configuration must be JSON-able (Decoder.config()), got "
                             f"{_short(config)}: {exc}.") from None
    rebuilt = _as_json(decoder.config())
    if rebuilt == saved:
        return
    keys = sorted(k for k in set(rebuilt) | set(saved) if rebuilt.get(k) != saved.get(k))
    detail = "; ".join(f"{k}: saved {_short(saved.get(k))}, rebuilt {_short(rebuilt.get(k))}" for k in keys[:4])
    raise EmbeddingError(f"the rebuilt {rebuilt.get('kind')} decoder differs from the saved configuration in {keys} "
                         f"({detail}); rebuild it on the parameter space the file was written with.")


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def decoder_from_config(config: Mapping[str, Any], space: ParameterSpace) -> Decoder:
    """The decoder on ``space`` whose ``config()`` equals ``config`` (the registered class of its ``kind``).

    Raises :class:`EmbeddingError` for a configuration that is not a dict, an unknown kind (the
    message lists the known kinds), missing options, or a rebuilt decoder whose configuration
    differs from the saved one.
    """
    if not isinstance(space, ParameterSpace):
        raise EmbeddingError(f"decoder_from_config needs a physics ParameterSpace, got {type(space).__name__}.")
    kind = config.get("kind") if isinstance(config, Mapping) else None
    if kind in _BUILT_IN and kind not in _REGISTRY:
        importlib.import_module(_BUILT_IN[kind])
    if kind not in _REGISTRY:
        raise EmbeddingError(f"unknown decoder kind {kind!r} in the saved configuration; known kinds: "
                             f"{list(registered_kinds())} (register others with @embeddings.register_decoder).")
    decoder = _REGISTRY[kind].from_config(config, space)
    check_config(decoder, config)
    return decoder


def load_decoder(path: str | os.PathLike[str], space: ParameterSpace) -> Decoder:
    """The decoder saved with ``decoder.save(path)`` (its kind read from the file), on ``space``.

    Raises :class:`EmbeddingError` for a missing or unreadable file, or one written on another
    parameter space (names or bounds differ).
    """
    try:
        record = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise EmbeddingError(f"no decoder file at {path}; train one with `tensegrid train-embedding`.") from None
    except (OSError, ValueError) as exc:
        raise EmbeddingError(f"cannot read the decoder file {path}: {exc}") from None
    if not isinstance(record, dict) or "decoder" not in record:
        raise EmbeddingError(f"{path} is not a saved decoder (no 'decoder' entry); write it with decoder.save(path).")
    decoder = decoder_from_config(record["decoder"], space)
    decoder.restore(record)
    return decoder
