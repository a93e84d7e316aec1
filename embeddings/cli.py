"""``tensegrid train-embedding``: train a decoder and save it for ``tensegrid identify --decoder-file``.

::

    tensegrid train-embedding vae    --out vae.json [--dim 5] [--samples 20000] [--epochs 100] [--seed 0]
    tensegrid train-embedding ae-dyn --out ae.json  [--dim 5] [--trajectories 1200] [--summary com]
                                     [--counterfactual] [--workers 2] [--cache DIR] [--epochs 100] [--seed 0]
    tensegrid train-embedding ae-dyn --toy push --dim 1 --out push-ae.json

``vae`` trains on θ drawn from the box. ``ae-dyn`` first simulates the transition set (cached in
``--cache``, default ``.cache/tensegrid`` or $TENSEGRID_CACHE), trains the dynamics network on
80 % of its trajectories and prints its held-out error against predicting the mean, then trains
the autoencoder through it. With ``--counterfactual`` the network predicts what θ changes against
the nominal θ from the same state (embeddings.t6_data), which it resolves far better. The decoder
file is JSON (weights and their sha256 included); the dynamics network is saved beside it as
``<out>.dynamics.json``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from embeddings.trained import TrainedDecoder
    from embeddings.transitions import Transitions
    from physics.parameters import ParameterSpace

__all__ = ["register_train_embedding", "run_train_embedding"]


def register_train_embedding(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add the ``train-embedding`` sub-command to a ``tensegrid`` argparse sub-parser collection."""
    p = subparsers.add_parser("train-embedding", help="train a decoder (VAE, dynamics-aware autoencoder) and save it",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("kind", choices=["vae", "ae-dyn"])
    p.add_argument("--out", required=True, help="decoder file to write (JSON)")
    p.add_argument("--toy", choices=["push"], help="the 1-D push toy's space (m, mu) instead of the T6")
    p.add_argument("--dim", type=int, default=None, help="latent dimension (default 5; 1 for --toy push)")
    p.add_argument("--hidden", type=int, default=None, help="hidden width (vae 400, ae-dyn 10; push 32)")
    p.add_argument("--samples", type=int, default=20000, help="vae: θ draws; ae-dyn --toy push: pushes")
    p.add_argument("--trajectories", type=int, default=1200, help="ae-dyn on the T6: simulated trajectories")
    p.add_argument("--summary", choices=["com", "com_height", "nodes"], default="com",
                   help="ae-dyn on the T6: what the dynamics network predicts (com_height is the paper's)")
    p.add_argument("--counterfactual", action="store_true",
                   help="ae-dyn on the T6: the target is what θ changes against the nominal θ from the same state")
    p.add_argument("--epochs", type=int, default=100)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=2, help="dask workers that simulate the T6 transitions")
    p.add_argument("--cache", default=None, help="folder of cached transition sets")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=run_train_embedding)


def _space(args: argparse.Namespace) -> ParameterSpace:
    from physics.parameters import ParameterSpace
    from physics.push import push_space

    return push_space() if args.toy == "push" else ParameterSpace.t6()


def _transitions(args: argparse.Namespace, space: ParameterSpace) -> Transitions:
    from embeddings.t6_data import DEFAULT_CACHE, T6DataConfig, t6_transitions
    from embeddings.transitions import push_transitions

    if args.toy == "push":
        if args.counterfactual:
            from embeddings.errors import EmbeddingError
            raise EmbeddingError("--counterfactual applies to the T6's simulated transitions; the push toy's "
                                 "target already depends on θ alone. Drop --counterfactual or --toy push.")
        return push_transitions(space, args.samples, seed=args.seed)
    config = T6DataConfig(n_trajectories=args.trajectories, summary=args.summary, seed=args.seed,
                          counterfactual=args.counterfactual)
    return t6_transitions(config, space=space, cache_dir=args.cache or DEFAULT_CACHE, workers=args.workers,
                          progress=not args.no_progress)


def _train(args: argparse.Namespace) -> TrainedDecoder:
    from embeddings.autoencoder import DynamicsAutoencoder
    from embeddings.dynamics import DynamicsNetwork
    from embeddings.networks import TrainingConfig
    from embeddings.vae import VAE

    space, push = _space(args), args.toy == "push"
    dim = args.dim or (1 if push else 5)
    progress = not args.no_progress
    if args.kind == "vae":
        vae = VAE(space, dim=dim, hidden=args.hidden or 400)
        return vae.fit(args.samples, training=TrainingConfig(epochs=args.epochs, seed=args.seed), progress=progress)
    data = _transitions(args, space)
    train, test = data.split(0.2, seed=args.seed)
    dynamics = DynamicsNetwork(space, hidden=(64, 128, 64) if push else (128, 64, 32))
    dynamics.fit(train, training=TrainingConfig(epochs=args.epochs, batch_size=128 if push else 256, seed=args.seed),
                 progress=progress)
    score = dynamics.score(test)
    print(f"dynamics network: held-out MSE {score.mse:.4g} vs {score.baseline_mse:.4g} predicting the mean "
          f"(ratio {score.ratio:.3f}) on {len(test)} rows of {len(set(test.group))} held-out trajectories")
    dynamics.save(Path(args.out).with_suffix(".dynamics.json"))
    autoencoder = DynamicsAutoencoder(space, dim=dim, hidden=args.hidden or (32 if push else 10))
    return autoencoder.fit(dynamics, train, training=TrainingConfig(epochs=args.epochs, batch_size=128, lr=3e-3,
                                                                seed=args.seed), progress=progress)


def run_train_embedding(args: argparse.Namespace) -> int:
    """Handler of ``tensegrid train-embedding``; returns the exit code (0 ok, 2 usage or training error)."""
    from physics.errors import TensegridError

    try:
        decoder = _train(args)
        path = decoder.save(args.out)
    except TensegridError as exc:
        print(f"tensegrid train-embedding: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {path}: {decoder!r}; latent box {decoder.bounds.round(3).tolist()}")
    print(f"use it: tensegrid identify DATA.nc --decoder {args.kind} --decoder-file {path} --out DIR")
    return 0
