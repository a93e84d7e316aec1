"""Decoders shipped with the package, trained once for a parameter space users search as is.

``t6-ae-cf-5``: the 5-D dynamics-aware autoencoder trained through a network on the
counterfactual target (what θ changes against the nominal θ from the same state; docs/embeddings.md)
over the T6's default box (``ParameterSpace.t6()``, nominal ±10 %), the latent stage of the
``handoff`` presets (belief.presets). It is the ``ae-cf-5`` decoder of benchmarks/paper.py:
1,200 simulated trajectories of 1.5 s, 60 epochs for the network and the autoencoder, seeds 0;
``make pretrained`` retrains it and rewrites ``embeddings/data/t6-ae-cf-5.json``.

A decoder is only offered for the space it was trained on (same names, same bounds): on any
other box :func:`pretrained_decoder` returns None and the caller trains its own
(``tensegrid train-embedding``).
"""
from __future__ import annotations

from pathlib import Path

from embeddings.base import Decoder
from embeddings.registry import load_decoder
from physics.parameters import ParameterSpace

__all__ = ["PRETRAINED_T6", "pretrained_path", "pretrained_decoder"]

#: file name of the T6 latent decoder under embeddings/data/
PRETRAINED_T6 = "t6-ae-cf-5.json"


def pretrained_path(name: str = PRETRAINED_T6) -> Path:
    """Where the shipped decoder ``name`` lives (it may be absent in a checkout that has not built it)."""
    return Path(__file__).resolve().parent / "data" / name


def pretrained_decoder(space: ParameterSpace) -> Decoder | None:
    """The shipped latent decoder for ``space``, or None when none was trained on exactly this box."""
    path = pretrained_path()
    if not path.exists() or not space.same_box(ParameterSpace.t6()):
        return None
    return load_decoder(path, space)
