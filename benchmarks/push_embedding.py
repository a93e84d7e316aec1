"""The 1-D push toy (Zhu et al. 2018, Sec. IV-C-1, Fig. 5): BO in the learned 1-D latent against BO
and random search in (m, μ), over many truths.

    .venv/bin/python benchmarks/push_embedding.py [--seeds 20] [--budget 30]

Trains the dynamics network and the autoencoder once (20,000 pushes, as in the paper), then for
each seed draws a truth uniformly in the box and 8 noiseless pushes, and runs each method with
the same number of evaluations. Prints the median best displacement error E [m²] after 5, 10,
15, 20 and 30 evaluations and how often the latent wins; writes
benchmarks/results/push_embedding.json and docs/figures/push_embedding.png.
"""
from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _train(space):
    from scipy.stats import spearmanr

    from embeddings import DynamicsAutoencoder, DynamicsNetwork, TrainingConfig, push_transitions

    data = push_transitions(space, 20000, seed=0)
    train, test = data.split(0.1, seed=0)
    dynamics = DynamicsNetwork(space, hidden=(64, 128, 64)).fit(
        train, training=TrainingConfig(epochs=30, batch_size=128, seed=0))
    ae = DynamicsAutoencoder(space, dim=1, hidden=32).fit(
        dynamics, train, training=TrainingConfig(epochs=30, batch_size=128, lr=3e-3, seed=0))
    rho = spearmanr(ae.encode(test.theta)[:, 0], test.theta[:, 0] ** 2 * test.theta[:, 1]).correlation
    return dynamics.score(test), ae, float(rho)


def _curves(space, ae, seeds: int, budget: int) -> dict[str, np.ndarray]:
    from tqdm import tqdm

    from belief import Grid, identify
    from embeddings import Identity
    from physics.push import PushObjective, generate_push_data

    identity = Identity(space)
    methods = {"BO, learned 1-D latent": (ae, Grid.for_decoder(ae, points_per_dim=1001), "bo"),
               "BO, (m, mu)": (identity, Grid.for_decoder(identity, points_per_dim=31), "bo"),
               "random, (m, mu)": (identity, Grid.for_decoder(identity, points_per_dim=31), "random")}
    curves: dict[str, list[np.ndarray]] = {name: [] for name in methods}
    for seed in tqdm(range(seeds), desc="truths"):
        truth = space.sample(1, seed=100 + seed)[0]
        J, S = generate_push_data(truth, n=8, seed=seed)
        objective = PushObjective(J, S, space=space)
        for name, (decoder, grid, method) in methods.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = identify(objective, decoder, grid, budget=budget, seed=seed, proposer=method, progress=False)
            curves[name].append(np.minimum.accumulate(result.history["error"].values))
    return {name: np.array(c) for name, c in curves.items()}


def _plot(curves: dict[str, np.ndarray], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    x = np.arange(1, next(iter(curves.values())).shape[1] + 1)
    for name, c in curves.items():
        q25, med, q75 = np.percentile(c, [25, 50, 75], axis=0)
        ax.plot(x, med, label=name)
        ax.fill_between(x, q25, q75, alpha=0.2)
    ax.set_yscale("log")
    ax.set_xlabel("evaluations")
    ax.set_ylabel("best displacement error E [m²]")
    ax.set_title(f"push toy: median and quartiles over {len(next(iter(curves.values())))} truths")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--budget", type=int, default=30)
    args = parser.parse_args()
    from physics.push import push_space

    space = push_space()
    start = time.perf_counter()
    score, ae, rho = _train(space)
    trained = time.perf_counter() - start
    curves = _curves(space, ae, args.seeds, args.budget)
    print(f"dynamics network held-out MSE {score.mse:.3g} m² vs {score.baseline_mse:.3g} for the mean "
          f"(ratio {score.ratio:.4f}); latent vs m²μ Spearman {rho:.4f}; training {trained:.0f} s")
    budgets = [b for b in (5, 10, 15, 20, 30) if b <= args.budget]
    print("| method | " + " | ".join(f"median E after {b}" for b in budgets) + " |")
    print("|---|" + "---|" * len(budgets))
    for name, c in curves.items():
        print(f"| {name} | " + " | ".join(f"{np.median(c[:, b - 1]):.2e}" for b in budgets) + " |")
    latent, full = curves["BO, learned 1-D latent"], curves["BO, (m, mu)"]
    print("latent lower than (m, mu) BO in " + ", ".join(
        f"{int(np.sum(latent[:, b - 1] < full[:, b - 1]))}/{len(latent)} truths at {b}" for b in budgets))
    out = ROOT / "benchmarks" / "results" / "push_embedding.json"
    out.write_text(json.dumps({"seeds": args.seeds, "budget": args.budget, "spearman": rho,
                               "dynamics_mse": score.mse, "dynamics_baseline_mse": score.baseline_mse,
                               "curves": {k: v.tolist() for k, v in curves.items()}}))
    _plot(curves, ROOT / "docs" / "figures" / "push_embedding.png")
    print(f"wrote {out} and docs/figures/push_embedding.png")


if __name__ == "__main__":
    main()
