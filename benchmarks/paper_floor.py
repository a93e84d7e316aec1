"""Why a trained decoder helps or not: what the dynamics network sees of θ, and each decoder's floor.

    .venv/bin/python benchmarks/paper_floor.py [--truths 2] [--chain 1 3 6] [--spread-only]

Uses the decoders and the dynamics network that benchmarks/paper.py trains (same settings, same cache).
Prints

* the dynamics network's visibility of θ on held-out trajectories: s, the variance of its
  standardized prediction that θ alone causes at fixed contexts, against e, its standardized
  held-out error (``DynamicsNetwork.theta_visibility``); s < e means a loss through the network
  cannot tell θ apart better than the network's own error; with ``--chain m ...`` the same for a
  centre-of-mass target m times further ahead, made by chaining the cached rows (a row's target
  plus those of the rows one horizon, two horizons ... later), each with its own network; and the
  same for the network on the counterfactual target (what θ changes against the nominal θ);
* per decoder and truth (nominal, then draws inside the box as in paper.py): the largest parameter
  error of decode(encode(θ*)) in %, the fitting error E there, and E at the latent grid point
  nearest to encode(θ*) (the search's resolution), next to E(θ*) itself. A decoder whose
  decode(encode(θ*)) has E far above E(θ*) cannot reach the truth at any budget;
* per decoder, where its image lies in the parameter box (u = (θ - lower) / width): the mean
  |u - 0.5| over the decoded cells of its latent grid, and the share of coordinates within 1 % of
  a face (uniform θ: 0.25 and 2 %), then the same over the cells nearest encode(θ_k) for 64 Sobol
  θ_k of the box (benchmarks/paper_dev.py pulls the image inward with a centre prior and measures
  what that does to the search); and how coarse the full space's candidates are: the median
  distance from 200 uniform points of the unit box to the nearest of paper.py's 4096 Sobol
  candidates (seed 0).
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from paper import FIT_FLOPS, ROOT, Settings, cache_folder, dynamics_network, observe, train_decoders  # noqa: E402


def floor_row(decoder, truth: np.ndarray, objective, points_per_dim: int) -> tuple[float, float, float]:
    """(max % error of decode(encode(θ*)), E there, E at the nearest grid point of the latent box)."""
    z = np.atleast_2d(decoder.encode(truth[None]))[0]
    bounds = decoder.bounds
    step = (bounds[:, 1] - bounds[:, 0]) / (points_per_dim - 1)
    snapped = bounds[:, 0] + np.round((np.clip(z, bounds[:, 0], bounds[:, 1]) - bounds[:, 0]) / step) * step
    back, grid = decoder.decode(z[None])[0], decoder.decode(snapped[None])[0]
    return float(100 * np.max(np.abs(back - truth) / np.abs(truth))), float(objective(back)), float(objective(grid))


def image_spread(decoder, points_per_dim: int, *, n_prior: int = 64) -> tuple[float, float, float, float]:
    """(mean |u - 0.5|, share of u within 0.01 of a face) over the decoded grid, then over the cells
    nearest encode(θ_k) for ``n_prior`` Sobol θ_k of the box (module docstring)."""
    from scipy.stats import qmc

    from belief.grid import Grid

    grid = Grid.for_decoder(decoder, points_per_dim=points_per_dim)
    space = decoder.space
    theta = space.lower + qmc.Sobol(space.dim, scramble=True, seed=0).random(n_prior) * (space.upper - space.lower)
    out = []
    for cells in (np.arange(grid.size), grid.nearest(np.atleast_2d(decoder.encode(theta)))):
        u = space.to_unit(decoder.decode(grid.points[cells]))
        out += [float(np.mean(np.abs(u - 0.5))), float(np.mean((u < 0.01) | (u > 0.99)))]
    return tuple(out)


def candidate_spacing(dim: int, n: int, *, probes: int = 200) -> float:
    """Median Euclidean distance in the unit cube [0, 1]^dim from ``probes`` uniform points (seed 0)
    to the nearest of ``n`` scrambled Sobol points (seed 0)."""
    from scipy.stats import qmc

    candidates = qmc.Sobol(dim, scramble=True, seed=0).random(n)
    points = np.random.default_rng(0).random((probes, dim))
    return float(np.median([np.sqrt(((candidates - x) ** 2).sum(axis=1)).min() for x in points]))


def chained(data, m: int, rows_per_horizon: int):
    """Transitions whose target is the sum of m consecutive horizons' targets (same trajectory only)."""
    from embeddings import Transitions

    span = rows_per_horizon * (m - 1)
    keep = np.array([k for k in range(len(data) - span) if data.group[k + span] == data.group[k]])
    target = sum(data.target[keep + rows_per_horizon * j] for j in range(m))
    return Transitions(data.theta[keep], data.context[keep], target, data.group[keep], data.parameter_names,
                       data.context_names, data.target_names)


def visibility(space, settings: Settings, cache: Path, chain: list[int]) -> None:
    """Print s, e and s/e of the paper's dynamics network and of networks on chained targets."""
    from embeddings import DynamicsNetwork, T6DataConfig, TrainingConfig

    base, train, test = dynamics_network(space, settings, cache, cache_folder(settings, cache))
    config, rows = T6DataConfig(), T6DataConfig().horizon // T6DataConfig().stride
    for m in chain:
        dynamics, held = base, test
        if m > 1:
            held = chained(test, m, rows)
            dynamics = DynamicsNetwork(space).fit(chained(train, m, rows),
                                                  training=TrainingConfig(epochs=settings.dyn_epochs))
        s, e = dynamics.theta_visibility(held)
        print(f"dynamics network ({settings.summary} target {m * config.horizon} samples ahead), held-out: "
              f"θ-induced variance s = {s:.3g}, error e = {e:.3g} (standardized), s/e = {s / e:.2f}", flush=True)
    counterfactual, _, held = dynamics_network(space, settings, cache, cache_folder(settings, cache),
                                               counterfactual=True)
    s, e = counterfactual.theta_visibility(held)
    print(f"dynamics network (counterfactual {settings.summary} target, θ against nominal, {config.horizon} samples "
          f"ahead), held-out: s = {s:.3g}, e = {e:.3g}, s/e = {s / e:.2f}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--truths", type=int, default=2, help="truths drawn inside the box (besides nominal)")
    parser.add_argument("--cache", default=str(ROOT / ".cache" / "tensegrid"))
    parser.add_argument("--chain", type=int, nargs="+", default=[1], help="target horizons, in stored horizons")
    parser.add_argument("--spread-only", action="store_true", help="only the table of where each image lies")
    args = parser.parse_args()
    from physics import TrajectoryObjective
    from physics.parameters import ParameterSpace

    warnings.simplefilter("ignore")
    space, settings, cache = ParameterSpace.t6(), Settings(), Path(args.cache)
    decoders = train_decoders(space, settings, cache)
    print("| decoder | grid: mean abs(u - 0.5) | grid: on a face | prior design: mean abs(u - 0.5) | prior design: on a face |")
    print("|---|---|---|---|---|")
    for name, decoder in decoders.items():
        spread = image_spread(decoder, settings.points_per_dim)
        print(f"| {name} | {spread[0]:.3f} | {spread[1]:.0%} | {spread[2]:.3f} | {spread[3]:.0%} |", flush=True)
    gap = candidate_spacing(space.dim, settings.candidates)
    print(f"\nnearest of {settings.candidates} Sobol candidates in the unit {space.dim}-cube: median distance "
          f"{gap:.2f}, {gap / np.sqrt(space.dim):.2f} per coordinate")
    if args.spread_only:
        return
    visibility(space, settings, cache, args.chain)
    truths = [("nominal", space.nominal)] + [(f"box{k + 1}", space.sample(1, seed=1000 + k)[0])
                                             for k in range(args.truths)]
    print("\n| decoder | truth | E(θ*) | max error of decode(encode(θ*)) | E there | E at the nearest grid point |")
    print("|---|---|---|---|---|---|")
    for label, truth in truths:
        with TrajectoryObjective(observe(space, truth, FIT_FLOPS, settings, 0.0, 0), loss="squared", windows=3,
                             n_workers=0) as objective:
            at_truth = float(objective(truth))
            for name, decoder in decoders.items():
                err, there, grid = floor_row(decoder, truth, objective, settings.points_per_dim)
                print(f"| {name} | {label} | {at_truth:.2g} | {err:.1f} % | {there:.3g} | {grid:.3g} |", flush=True)


if __name__ == "__main__":
    main()
