"""ae-cf-5 with a centre prior, tried on development truths that benchmarks/paper.py never scores.

    .venv/bin/python benchmarks/paper_dev.py [--weights 0 0.1] [--truths 4] [--out DIR]

ae-cf-5 (the autoencoder trained through the network on the counterfactual target) decodes much
of its latent box onto the faces of the parameter box (``paper_floor.py --spread-only``). A
centre prior (``DynamicsAutoencoder(centre_weight=λ)``: λ · 12 s · mean (u' - ½)² added to the
loss, s the θ-induced variance of the network's output; embeddings.autoencoder) pulls the image
inward. Whether that helps the search is asked on truths the comparison does not score, so that
the answer cannot be tuned to paper.py's problems:

* per λ in ``--weights``: ae-cf-5 retrained with that λ (λ = 0 is paper.py's cached ae-cf-5),
  and where its image lies (mean |u - 0.5| over the decoded grid, share of coordinates within 1 %
  of a face; uniform θ: 0.25 and 2 %);
* ``ae-cf-bo-gn`` with each of them, and ``bo-15`` once, on ``--truths`` θ* drawn inside the box with
  seeds 2000 + k (paper.py's truths use 1000 + k), with 0 and 1 mm noise, search seed 0; the
  problems, held-out flops and scoring are paper.py's;
* the mean log10 held-out E at the best θ after 5, 10, 20, 30, 45 and 60 evaluations.

Rows go to DIR/<method>-w<λ>/paper.jsonl and a row already there is skipped, so a run resumes.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from paper import (ROOT, Settings, cache_folder, dynamics_network, run_problem, train_autoencoder,  # noqa: E402
                   train_decoders)
from paper_floor import image_spread  # noqa: E402

BUDGETS = (5, 10, 20, 30, 45, 60)


def centre_decoder(space, settings: Settings, cache: Path, weight: float, out: Path):
    """ae-cf-5 trained with ``centre_weight=weight`` (saved under ``out``); weight 0 is paper.py's own."""
    from embeddings import load_decoder

    if weight == 0:
        return train_decoders(space, settings, cache)["ae-cf-5"]
    path = out / f"ae-cf-w{weight:g}.json"
    if not path.exists():
        folder = cache_folder(settings, cache)
        dynamics, train, _ = dynamics_network(space, settings, cache, folder, counterfactual=True)
        train_autoencoder(space, dynamics, train, settings, weight).save(path)
    return load_decoder(path, space)


def table(folders: list[Path]) -> None:
    """Mean log10 held-out E at each of ``BUDGETS`` per run folder and noise level."""
    print("| run | noise [m] | runs | " + " | ".join(str(b) for b in BUDGETS) + " |")
    print("|---|---|---|" + "---|" * len(BUDGETS))
    for folder in folders:
        rows = [json.loads(line) for line in open(folder / "paper.jsonl") if line.strip()]
        for noise in sorted({r["noise"] for r in rows}):
            runs = [r["heldout"] for r in rows if r["noise"] == noise]
            cells = [np.mean([np.log10(h[min(b, len(h)) - 1]) for h in runs]) for b in BUDGETS]
            print(f"| {folder.name} | {noise:g} | {len(runs)} | " + " | ".join(f"{c:.2f}" for c in cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--weights", type=float, nargs="+", default=[0.0, 0.1])
    parser.add_argument("--truths", type=int, default=4)
    parser.add_argument("--out", default=str(ROOT / ".cache" / "tensegrid" / "paper-dev"))
    parser.add_argument("--cache", default=str(ROOT / ".cache" / "tensegrid"))
    args = parser.parse_args()
    from physics.parameters import ParameterSpace

    space, settings, cache, out = ParameterSpace.t6(), Settings(), Path(args.cache), Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    runs = [("bo-15", None, "bo-15")] + [(f"ae-cf-bo-gn-w{w:g}", w, "ae-cf-bo-gn") for w in args.weights]
    print("| λ | grid: mean abs(u - 0.5) | grid: on a face |\n|---|---|---|")
    decoders = {}
    for _, weight, _ in runs[1:]:
        decoders[weight] = centre_decoder(space, settings, cache, weight, out)
        spread = image_spread(decoders[weight], settings.points_per_dim)
        print(f"| {weight:g} | {spread[0]:.3f} | {spread[1]:.0%} |", flush=True)
    for k in range(args.truths):
        truth = space.sample(1, seed=2000 + k)[0]
        for noise in (0.0, 0.001):
            for tag, weight, method in runs:
                folder = out / tag
                folder.mkdir(exist_ok=True)
                run_problem(space, truth, noise, {"truth_kind": "dev", "truth_index": k}, [method],
                            {"ae-cf-5": decoders.get(weight)}, settings, folder, 0)
    table([out / tag for tag, _, _ in runs])


if __name__ == "__main__":
    main()
