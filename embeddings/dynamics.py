"""The learned dynamics network of Zhu et al. 2018 (Sec. III-D, Fig. 3a): (θ, context) -> next summary.

::

    inputs    u = (θ - lower) / (upper - lower)   (n, D)     and the context x (n, c), standardized
    network   [u, x̂] -> hidden layers (ReLU) -> ŷ (n, k), the standardized target
    loss      mean over rows and outputs of (ŷ - (y - mean_y) / std_y)²

The standardization constants are buffers of the module, so they travel with its weights. The
network is the differentiable stand-in for the simulator through which the dynamics-aware
autoencoder (:mod:`embeddings.autoencoder`) is trained; its quality is measured on held-out
trajectories against the baseline of predicting the training mean (:meth:`DynamicsNetwork.score`).
"""
from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from embeddings.base import write_json
from embeddings.errors import EmbeddingError
from embeddings.networks import TrainingConfig, mlp, pack_weights, seeded, train, unpack_weights
from embeddings.transitions import Transitions
from physics.parameters import ParameterSpace

__all__ = ["DynamicsNetwork", "DynamicsScore"]


class _Net(nn.Module):
    """MLP on standardized inputs with the standardization constants as buffers."""

    x_mean: torch.Tensor
    x_std: torch.Tensor
    y_mean: torch.Tensor
    y_std: torch.Tensor

    def __init__(self, n_theta: int, n_context: int, n_target: int, hidden: Sequence[int]) -> None:
        super().__init__()
        self.body = mlp([n_theta + n_context, *hidden, n_target])
        for name, size in (("x_mean", n_context), ("x_std", n_context), ("y_mean", n_target), ("y_std", n_target)):
            self.register_buffer(name, torch.zeros(size) if "mean" in name else torch.ones(size))

    def forward(self, u: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        """Standardized prediction (n, k) from unit θ (n, D) and raw context (n, c)."""
        return self.body(torch.cat([u, (x - self.x_mean) / self.x_std], dim=1))


@dataclass(frozen=True)
class DynamicsScore:
    """Held-out mean squared error of the network and of predicting the training mean (target units²)."""

    mse: float
    baseline_mse: float

    @property
    def ratio(self) -> float:
        """mse / baseline_mse: below 1 means the network beats the mean."""
        return self.mse / self.baseline_mse if self.baseline_mse > 0 else float("inf")


class DynamicsNetwork:
    """(θ, context) -> target summary, an MLP with ``hidden`` layers (paper, T6: 128, 64, 32; push: 64, 128, 64).

    ``space`` gives the box that normalizes θ; ``fit(transitions)`` trains it; ``predict`` works
    on numpy arrays, ``forward_unit`` on torch tensors of unit θ (differentiable, for the autoencoder).
    """

    def __init__(self, space: ParameterSpace, *, hidden: Sequence[int] = (128, 64, 32)) -> None:
        if not hidden or any(not isinstance(h, (int, np.integer)) or h < 1 for h in hidden):
            raise EmbeddingError(f"DynamicsNetwork hidden must be a non-empty list of positive widths, got {hidden!r}.")
        self.space, self.hidden = space, tuple(int(h) for h in hidden)
        self.net: _Net | None = None
        self.context_names: tuple[str, ...] = ()
        self.target_names: tuple[str, ...] = ()
        self.history: list[float] = []

    def _require(self) -> _Net:
        if self.net is None:
            raise EmbeddingError("DynamicsNetwork is not trained: call fit(transitions) or "
                                 "DynamicsNetwork.load(path, space).")
        return self.net

    def fit(self, data: Transitions, *, training: TrainingConfig | None = None,
            progress: bool = False) -> DynamicsNetwork:
        """Train on ``data`` (its θ must live in this network's space); returns self."""
        training = training or TrainingConfig(epochs=100, batch_size=256, lr=1e-3)
        u = torch.as_tensor(data.unit_theta(self.space), dtype=torch.float32)
        x = torch.as_tensor(data.context, dtype=torch.float32)
        y = torch.as_tensor(data.target, dtype=torch.float32)
        with seeded(training.seed):
            net = _Net(u.shape[1], x.shape[1], y.shape[1], self.hidden)
        with torch.no_grad():
            net.x_mean.copy_(x.mean(0))
            net.x_std.copy_(x.std(0).clamp_min(1e-8))
            net.y_mean.copy_(y.mean(0))
            net.y_std.copy_(y.std(0).clamp_min(1e-12))
        y_std = (y - net.y_mean) / net.y_std

        def loss(rows: torch.Tensor, _: torch.Generator) -> torch.Tensor:
            return ((net(u[rows], x[rows]) - y_std[rows]) ** 2).mean()

        self.history = train(net.parameters(), loss, len(data), training, progress=progress, desc="dynamics network")
        self.net, self.context_names, self.target_names = net, data.context_names, data.target_names
        return self

    def forward_unit(self, u: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        """Standardized prediction (n, k) from unit θ and raw context tensors; differentiable in u."""
        return self._require()(u, x)

    def standardize(self, y: torch.Tensor) -> torch.Tensor:
        """(y - mean) / std of the training targets, the scale :meth:`forward_unit` predicts on."""
        net = self._require()
        return (y - net.y_mean) / net.y_std

    def predict(self, theta: np.ndarray, context: np.ndarray) -> np.ndarray:
        """Target (n, k) in physical units for θ (n, D) and context (n, c)."""
        net = self._require()
        u = torch.as_tensor(self.space.to_unit(np.atleast_2d(theta)), dtype=torch.float32)
        with torch.no_grad():
            out = net(u, torch.as_tensor(np.atleast_2d(context), dtype=torch.float32)) * net.y_std + net.y_mean
        return out.numpy().astype(float)

    def theta_sensitivity(self, u: torch.Tensor, x: torch.Tensor, *, seed: int = 0, rows: int = 4096) -> float:
        """s = ½ mean || g(u_π, x) - g(u, x) ||² / k over up to ``rows`` rows, π a seeded pairing.

        u: unit θ (n, D), x: contexts (n, c). The variance of the standardized prediction that θ
        alone causes at fixed contexts: what a loss through this network can see of θ.
        """
        net = self._require()
        generator = torch.Generator().manual_seed(int(seed))
        pick = torch.randperm(len(u), generator=generator)[:rows]
        other = pick[torch.randperm(len(pick), generator=generator)]
        with torch.no_grad():
            return float(0.5 * ((net(u[other], x[pick]) - net(u[pick], x[pick])) ** 2).mean())

    def theta_visibility(self, test: Transitions, *, seed: int = 0) -> tuple[float, float]:
        """(s, e): θ-induced variance (:meth:`theta_sensitivity`) and held-out error, both standardized.

        e = mean (g(u, x) - (y - mean_y)/std_y)² on ``test``. When s < e the network's own error is
        larger than anything θ does to its output, and a decoder trained through it cannot
        resolve θ to better than that.
        """
        net = self._require()
        u = torch.as_tensor(test.unit_theta(self.space), dtype=torch.float32)
        x = torch.as_tensor(test.context, dtype=torch.float32)
        y = self.standardize(torch.as_tensor(test.target, dtype=torch.float32))
        with torch.no_grad():
            error = float(((net(u, x) - y) ** 2).mean())
        return self.theta_sensitivity(u, x, seed=seed), error

    def score(self, test: Transitions, train_mean: np.ndarray | None = None) -> DynamicsScore:
        """Held-out MSE of the network vs predicting the training targets' mean, averaged over outputs."""
        net = self._require()
        pred = self.predict(test.theta, test.context)
        mean = net.y_mean.numpy() if train_mean is None else np.asarray(train_mean)
        return DynamicsScore(float(np.mean((pred - test.target) ** 2)), float(np.mean((mean - test.target) ** 2)))

    def save(self, path: str | os.PathLike[str]) -> Path:
        """JSON with the architecture, names, packed weights (with sha256) and loss history."""
        net = self._require()
        record = {"kind": "dynamics-network", "hidden": list(self.hidden), "names": list(self.space.names),
                  "lower": self.space.lower.tolist(), "upper": self.space.upper.tolist(),
                  "context_names": list(self.context_names), "target_names": list(self.target_names),
                  "weights": pack_weights(net), "history": self.history}
        return write_json(path, record)

    @classmethod
    def load(cls, path: str | os.PathLike[str], space: ParameterSpace) -> DynamicsNetwork:
        """A network saved with :meth:`save`, on ``space`` (names and bounds must match)."""
        try:
            record: dict[str, Any] = json.loads(Path(path).read_text())
        except (OSError, ValueError) as exc:
            raise EmbeddingError(f"cannot read a dynamics network from {path}: {exc}") from None
        if record.get("kind") != "dynamics-network":
            raise EmbeddingError(f"{path} is not a saved DynamicsNetwork (kind {record.get('kind')!r}).")
        if record["names"] != list(space.names) or not np.allclose(record["lower"], space.lower) \
                or not np.allclose(record["upper"], space.upper):
            raise EmbeddingError(f"the dynamics network in {path} was trained on another parameter space "
                                 f"({record['names']}); train it on this one.")
        network = cls(space, hidden=record["hidden"])
        network.context_names, network.target_names = tuple(record["context_names"]), tuple(record["target_names"])
        net = _Net(space.dim, len(network.context_names), len(network.target_names), network.hidden)
        network.net = unpack_weights(net, record["weights"])
        network.history = [float(v) for v in record.get("history", [])]
        return network

    def fingerprint(self) -> str:
        """sha256 of the weights (with the standardization constants)."""
        return pack_weights(self._require())["sha256"]
