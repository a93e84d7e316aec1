"""How much of the comparison at 5 evaluations is the draw of the initial design: many draws of it.

    .venv/bin/python benchmarks/paper_design.py [--seeds 32] [--truths 3] [--first 5]

At paper.py's smallest budget every method is still in its initial design, so its held-out error
there is that of the best of a few quasi-random points, and paper.py has one design per seed.
This script draws ``--seeds`` designs of each kind on paper.py's noiseless problems (θ* at nominal
and ``--truths`` draws inside the box, the same fitted and held-out flops):

* ``latent``: what ``ae-cf-bo-gn`` evaluates first, the cells of ae-cf-5's 11^5 latent grid nearest
  to a scrambled Sobol sequence (belief.sobol_design, n_init = 6), decoded;
* ``full``: what ``bo-15`` and ``botorch`` evaluate first, the first points of the scrambled Sobol
  sequence of the 15-D box (the same rule on paper.py's 4096 SobolCandidates, n_init = 16).

For n = 1 .. ``--first`` it prints the mean log10 held-out E at the θ of lowest fitted E among the
first n points, and the paired difference latent − full per (seed, truth): mean ± standard error
and on how many pairs latent is lower. Design s here is the design paper.py's ``--seed s`` uses.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from paper import FIT_FLOPS, HELD_OUT_FLOPS, ROOT, Settings, observe, train_decoders  # noqa: E402


def designs(space, decoder, settings: Settings, seed: int, first: int) -> dict[str, np.ndarray]:
    """θ (first x D) of each kind of initial design for ``seed``."""
    from belief.grid import Grid, SobolCandidates
    from belief.proposers import sobol_design
    from embeddings import Identity

    out = {}
    for kind, dec, grid in (("latent", decoder, Grid.for_decoder(decoder, points_per_dim=settings.points_per_dim)),
                            ("full", Identity(space), SobolCandidates.for_decoder(Identity(space), n=settings.candidates,
                                                                                  seed=seed))):
        cells = sobol_design(grid, max(first, dec.dim + 1), seed)[:first]
        out[kind] = dec.decode(grid.points[cells])
    return out


def best_so_far(fit: np.ndarray, held: np.ndarray) -> np.ndarray:
    """log10 held-out E at the θ of lowest fitted E among the first n, for n = 1 .. len(fit)."""
    best = [int(np.argmin(fit[:n])) for n in range(1, len(fit) + 1)]
    return np.log10(held[best])


def main() -> None:
    from physics import TrajectoryObjective
    from physics.parameters import ParameterSpace

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=32)
    parser.add_argument("--truths", type=int, default=3)
    parser.add_argument("--first", type=int, default=5)
    parser.add_argument("--cache", default=str(ROOT / ".cache" / "tensegrid"))
    args = parser.parse_args()
    from tqdm import tqdm

    space, settings = ParameterSpace.t6(), Settings()
    decoder = train_decoders(space, settings, Path(args.cache))["ae-cf-5"]
    truths = [space.nominal] + [space.sample(1, seed=1000 + k)[0] for k in range(args.truths)]
    curves: dict[str, list[np.ndarray]] = {"latent": [], "full": []}
    with tqdm(total=len(truths) * args.seeds, desc="designs") as bar:
        for truth in truths:
            fit = observe(space, truth, FIT_FLOPS, settings, 0.0, 0)
            held = observe(space, truth, HELD_OUT_FLOPS, settings, 0.0, 100)
            with TrajectoryObjective(fit, loss="squared", windows=3, n_workers=0) as e_fit, \
                    TrajectoryObjective(held, loss="squared", windows=1, n_workers=0) as e_held:
                for seed in range(args.seeds):
                    for kind, thetas in designs(space, decoder, settings, seed, args.first).items():
                        curves[kind].append(best_so_far(np.asarray(e_fit(thetas)), np.asarray(e_held(thetas))))
                    bar.update()
    report({k: np.array(v) for k, v in curves.items()}, args.first)


def report(curves: dict[str, np.ndarray], first: int) -> None:
    """The table of mean log10 held-out E and of the paired difference latent − full."""
    diff = curves["latent"] - curves["full"]
    pairs = len(diff)
    print(f"| n | latent | full | latent − full (mean ± s.e., {pairs} pairs) | latent lower |")
    print("|---|---|---|---|---|")
    for n in range(first):
        d = diff[:, n]
        print(f"| {n + 1} | {curves['latent'][:, n].mean():.2f} | {curves['full'][:, n].mean():.2f} | "
              f"{d.mean():+.2f} ± {d.std(ddof=1) / np.sqrt(pairs):.2f} | {int(np.sum(d < 0))} of {pairs} |")


if __name__ == "__main__":
    main()
