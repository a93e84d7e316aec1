"""The one-step error of each component the mismatch stage kept, on the fit flops and the held-out flop.

The stage (criticism.mismatch) keeps a component for the windowed fit error it removes. This
script reads the stages that benchmarks/effects.py journalled (``mismatch_stage.json`` under
``--journals``, first looks and second looks) and, for each kept component in the order it was
kept, scores the one-step error (horizon 1, every prediction from an observed sample) of the
model with it at its re-tuned θ over the model before it (the round's θ before the component:
the base θ in round 1, the previous kept component's θ after):

    fit ratio  = E1(fit flops, after) / E1(fit flops, before)
    held ratio = E1(held-out flop, after) / E1(held-out flop, before)

The stage's one-step guard (``MismatchConfig.max_one_step_rise``) decides on the fit ratio; the
held ratio, which the stage never sees, shows whether the fit ratio predicts it. A stage journal
names its testbed data set, seed and flops (the folder ``testbed-NAME-seedS-...``; flops version
2, 0.2 mm noise), and the data are checked against the journal's fingerprint.

    .venv/bin/python benchmarks/stage_one_step.py --journals .cache/effects-journals --out FILE
    .venv/bin/python benchmarks/stage_one_step.py --summarize FILE

Rows go to ``--out`` (JSON lines); a journal already there is skipped.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np
from jsonl_rows import read_rows
from tqdm.auto import tqdm

from criticism.held_out import one_step_error
from criticism.mismatch import in_order
from physics import TrajectoryObjective, load_trajectory
from physics.effects import Effect, effect_from_config

FOLDER = re.compile(r"testbed-(?P<name>[a-z_+]+?)-seed(?P<seed>\d+)-")


def _objective(name: str, seed: int, fingerprint: dict) -> TrajectoryObjective:
    """The stage's objective over flop_0, flop_1 and heldout_0 of the testbed data set, with the
    effects the stage started from; refuses one whose fingerprint is not the journal's."""
    from testbed.datasets import cached_dataset
    files = cached_dataset(name, seed, noise=0.0002, version=2)
    data = [load_trajectory(files[label]) for label in ("flop_0", "flop_1", "heldout_0")]
    start = tuple(effect_from_config(c) for c in fingerprint["objective"]["effects"])
    objective = TrajectoryObjective(data, horizon=25, loss="squared", windows=3, effects=start, n_workers=0)
    if json.dumps(objective.fingerprint(), sort_keys=True) != json.dumps(fingerprint["objective"], sort_keys=True):
        objective.close()
        raise SystemExit(f"{name} seed {seed}: the flops or the objective are not the ones the journal's stage saw.")
    return objective


def _scores(objective: TrajectoryObjective, effects: tuple[Effect, ...], theta: np.ndarray) -> tuple[float, float]:
    """One-step error [m²] of the fit flops (0, 1) and of the held-out flop (2) at θ."""
    model = objective.with_effects(effects)
    return one_step_error(model, theta, [0, 1]), one_step_error(model, theta, [2])


def run_one(path: Path) -> dict:
    """The row of one journalled stage (module docstring)."""
    match = FOLDER.search(str(path))
    if match is None:
        raise SystemExit(f"{path}: not under a testbed journal folder testbed-NAME-seedS-...")
    name, seed = match["name"], int(match["seed"])
    saved = json.loads(path.read_text())
    report, fingerprint = saved["report"], saved["fingerprint"]
    order = [c["effect"] for c in fingerprint["config"]["components"]]
    objective = _objective(name, seed, fingerprint)
    try:
        effects, theta = objective.effects, np.asarray(report["base_theta"], float)
        fit0, held0 = _scores(objective, effects, theta)
        kept = []
        for trial in (t for t in report["trials"] if t["kept"]):
            added = next(effect_from_config(c) for c in report["effects"] if c["effect"] == trial["name"])
            effects = in_order((*effects, added), order)
            theta = np.asarray(trial["theta"], float)
            fit1, held1 = _scores(objective, effects, theta)
            kept.append({"name": trial["name"], "round": trial["round"], "gain": trial["gain"],
                         "values": trial["values"], "fit_ratio": fit1 / fit0, "held_ratio": held1 / held0})
            fit0, held0 = fit1, held1
    finally:
        objective.close()
    return {"journal": str(path), "dataset": name, "seed": seed, "second_look": "revisit" in path.parent.name,
            "kept": kept}


def summarize(rows: list[dict]) -> None:
    """Per kept component: data set, seed, look, gain, fit and held ratios; then the largest fit ratio
    by component and how often fit and held ratios fall on the same side of the guard."""
    print(f"{'data set':16s} {'seed':>4} {'look':>6}  component (gain, fit ratio, held ratio) in the order kept")
    pairs = []
    for r in rows:
        parts = [f"{k['name']} ({k['gain']:.0%}, {k['fit_ratio']:.2f}, {k['held_ratio']:.2f})" for k in r["kept"]]
        look = "second" if r["second_look"] else "first"
        print(f"{r['dataset']:16s} {r['seed']:>4} {look:>6}  " + ("; ".join(parts) or "none kept"))
        pairs += [(k["name"], k["fit_ratio"], k["held_ratio"]) for k in r["kept"]]
    if not pairs:
        return
    print("\nlargest fit ratio by component: " + ", ".join(
        f"{n} {max(f for m, f, _ in pairs if m == n):.2f}" for n in sorted({p[0] for p in pairs})))
    for bar in (1.1,):
        same = sum((f > bar) == (h > bar) for _, f, h in pairs)
        print(f"fit and held ratios on the same side of {bar}: {same} of {len(pairs)}; above it on fit: "
              f"{sum(f > bar for _, f, _ in pairs)}, on held: {sum(h > bar for _, _, h in pairs)}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--journals", type=Path, nargs="*", default=[], help="folders searched for mismatch_stage.json")
    parser.add_argument("--out", type=Path, default=Path(".cache/stage-one-step.jsonl"))
    parser.add_argument("--summarize", type=Path, help="print the table of a rows file and stop")
    args = parser.parse_args(argv)
    if args.summarize:
        summarize(read_rows(args.summarize))
        return
    done = {r["journal"] for r in read_rows(args.out)}
    paths = sorted(p for folder in args.journals for p in folder.rglob("mismatch_stage.json")
                   if FOLDER.search(str(p)) and str(p) not in done)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    for path in tqdm(paths, desc="stages"):
        row = run_one(path)
        with args.out.open("a") as f:
            f.write(json.dumps(row) + "\n")
    summarize(read_rows(args.out))


if __name__ == "__main__":
    sys.exit(main())
