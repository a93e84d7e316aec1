"""Small torch building blocks shared by the trained decoders: multilayer perceptrons, seeded
minibatch training, and weights as text.

Weights travel inside a decoder's ``config()`` (so a journal or a saved belief names the exact
model, and a reloaded decoder decodes bit for bit the same): :func:`pack_weights` turns a module's
``state_dict`` into ``{"dtype", "tensors": {name: [shape, base64 of little-endian bytes]},
"sha256"}`` and :func:`unpack_weights` restores it, refusing a digest that does not match.
All networks here are float32; training runs on the CPU in one thread for repeatability.
"""
from __future__ import annotations

import base64
import contextlib
import hashlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
import torch
from torch import nn

from embeddings.errors import EmbeddingError

__all__ = ["mlp", "seeded", "pack_weights", "unpack_weights", "TrainingConfig", "train", "minibatches"]

_ACTIVATIONS: dict[str, Callable[[], nn.Module]] = {"relu": nn.ReLU, "tanh": nn.Tanh, "elu": nn.ELU}

_M = TypeVar("_M", bound=nn.Module)


def mlp(sizes: Sequence[int], *, activation: str = "relu", last: bool = False) -> nn.Sequential:
    """Linear layers ``sizes[0] -> sizes[1] -> ... -> sizes[-1]`` with ``activation`` between them
    (and after the last layer too when ``last``)."""
    if activation not in _ACTIVATIONS:
        raise EmbeddingError(f"activation must be one of {sorted(_ACTIVATIONS)}, got {activation!r}.")
    if len(sizes) < 2 or any(int(s) < 1 for s in sizes):
        raise EmbeddingError(f"layer sizes must be at least two positive integers, got {list(sizes)!r}.")
    layers: list[nn.Module] = []
    for k, (a, b) in enumerate(zip(sizes[:-1], sizes[1:], strict=True)):
        layers.append(nn.Linear(int(a), int(b)))
        if last or k < len(sizes) - 2:
            layers.append(_ACTIVATIONS[activation]())
    return nn.Sequential(*layers)


@contextlib.contextmanager
def seeded(seed: int) -> Iterator[None]:
    """Draw initial weights inside from ``seed``; torch's global random state is restored afterwards."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(int(seed))
        yield


def pack_weights(module: nn.Module) -> dict[str, Any]:
    """``module.state_dict()`` as JSON-able text with a sha256 over names, shapes and bytes."""
    tensors, digest = {}, hashlib.sha256()
    for name, tensor in module.state_dict().items():
        arr = np.ascontiguousarray(tensor.detach().cpu().numpy().astype("<f4"))
        raw = arr.tobytes()
        digest.update(name.encode() + repr(arr.shape).encode() + raw)
        tensors[name] = [list(arr.shape), base64.b64encode(raw).decode("ascii")]
    return {"dtype": "float32", "tensors": tensors, "sha256": digest.hexdigest()}


def unpack_weights(module: _M, packed: Any) -> _M:
    """Load :func:`pack_weights` output into ``module`` (same architecture); returns the module.

    Raises :class:`EmbeddingError` for a malformed record, a digest that does not match the bytes,
    or tensors that do not fit the architecture.
    """
    if not isinstance(packed, dict) or not {"tensors", "sha256"} <= set(packed):
        raise EmbeddingError("saved weights must be a dict with 'tensors' and 'sha256' "
                             "(embeddings.networks.pack_weights).")
    state, digest = {}, hashlib.sha256()
    try:
        for name, (shape, text) in packed["tensors"].items():
            raw = base64.b64decode(text.encode("ascii"))
            arr = np.frombuffer(raw, dtype="<f4").reshape(tuple(shape))
            digest.update(name.encode() + repr(arr.shape).encode() + raw)
            state[name] = torch.from_numpy(arr.astype(np.float32))
    except (TypeError, ValueError, AttributeError) as exc:
        raise EmbeddingError(f"saved weights are malformed ({exc}); save the decoder again.") from None
    if digest.hexdigest() != packed["sha256"]:
        raise EmbeddingError("saved weights do not match their sha256 (the file was altered or truncated); "
                             "train or save the decoder again.")
    try:
        module.load_state_dict(state)
    except RuntimeError as exc:
        raise EmbeddingError(f"saved weights do not fit the network's architecture: {exc}") from None
    return module


@dataclass(frozen=True)
class TrainingConfig:
    """Adam on minibatches: ``epochs`` passes, ``batch_size`` rows, learning rate ``lr``,
    ``weight_decay`` (L2), with the data order drawn from ``seed``."""

    epochs: int = 200
    batch_size: int = 256
    lr: float = 1e-3
    weight_decay: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("epochs", "batch_size"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or value < 1:
                raise EmbeddingError(f"TrainingConfig.{name} must be a positive integer, got {value!r}.")
        lr_ok = np.isfinite(self.lr) and self.lr > 0
        if not lr_ok or not (np.isfinite(self.weight_decay) and self.weight_decay >= 0):
            raise EmbeddingError("TrainingConfig needs lr > 0 and weight_decay >= 0, got "
                                 f"{self.lr!r}, {self.weight_decay!r}.")


def minibatches(n: int, batch_size: int, generator: torch.Generator) -> Iterator[torch.Tensor]:
    """Index tensors of a random permutation of ``range(n)`` in chunks of ``batch_size``."""
    order = torch.randperm(n, generator=generator)
    for start in range(0, n, batch_size):
        yield order[start:start + batch_size]


def train(parameters: Any, loss_fn: Callable[[torch.Tensor, torch.Generator], torch.Tensor], n: int,
          config: TrainingConfig, *, progress: bool = False, desc: str = "training") -> list[float]:
    """Minimize ``loss_fn(rows, generator)`` (mean loss of the rows ``rows`` of an n-row data set)
    with Adam; returns the mean training loss per epoch. One torch thread, seeded: the same data,
    config and initial weights give the same weights."""
    from tqdm.auto import tqdm

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        generator = torch.Generator().manual_seed(int(config.seed))
        opt = torch.optim.Adam(parameters, lr=config.lr, weight_decay=config.weight_decay)
        history: list[float] = []
        bar = tqdm(range(config.epochs), desc=desc, disable=not progress, leave=False)
        for _ in bar:
            total = 0.0
            for rows in minibatches(n, config.batch_size, generator):
                opt.zero_grad()
                loss = loss_fn(rows, generator)
                loss.backward()
                opt.step()
                total += float(loss.detach()) * len(rows)
            history.append(total / n)
            bar.set_postfix(loss=f"{history[-1]:.3g}")
        if not np.isfinite(history[-1]):
            raise EmbeddingError(f"{desc} diverged (loss {history[-1]!r}); lower TrainingConfig.lr.")
        return history
    finally:
        torch.set_num_threads(threads)
