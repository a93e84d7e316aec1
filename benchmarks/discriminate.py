"""One more flop for a tie: does the flop that separates two contenders most decide their contest?

On own-engine data of a contest scenario (benchmarks/effects.py protocol: two fitted flops, the
actuation flop held out), diagnose ranks the contenders; criticism.discrimination then simulates
both contenders' joint fits under the recorded flops and under 12 candidate flops (6 headings, two
actuation patterns) and ranks them by the separation s(u) of their predictions. The flop chosen by
``--add`` among the candidates that are no recorded flop again (``best``: the largest s;
``least``: the smallest, a control for "more data of any kind") is simulated from the true robot
with the scenario's effect and 0.2 mm noise, added as a third fitted flop, and diagnose runs again
on the same held-out flop. Printed: the separations, then the contest before and after; the row
(JSON) goes to ``--out``.

    .venv/bin/python benchmarks/discriminate.py --scenario sensor_bias --seed 0 --add best
    .venv/bin/python benchmarks/discriminate.py --scenario sensor_bias --seed 0 --add least
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from effects import diagnose_config, diagnose_row, make_data, scenario_effects

from criticism.diagnose import diagnose
from criticism.discrimination import Separation, flop_candidates, recorded_controllers, separations
from criticism.errors import CriticismError
from physics.effects import model_space
from physics.simulation import simulate

NOISE = 0.0002   # m, the benchmark's sensor noise


def contest(name: str, seed: int, budget: int, journal: Path | None) -> tuple[list, dict, list, dict]:
    """The scenario's data and θ*, the separations of its two best contenders, and their contest."""
    data, truth = make_data(name, seed)
    d = diagnose(data, held_out=[2], config=diagnose_config(budget, 1, seed), progress=False, journal_dir=journal)
    crit = d.passes[0].criticism
    pair = [c for c in crit.ranking if c.name in (crit.contest or {}).get("effects", [])][:2]
    if len(pair) < 2:
        raise CriticismError(f"{name} seed {seed}: no two contenders (ranking {[c.name for c in crit.ranking[:3]]}).")
    recorded = recorded_controllers(data)
    controllers = {**recorded, **flop_candidates()}
    seps = separations(d.first_model, pair[0], pair[1], controllers, recorded=list(recorded))
    before = {c.name: c.evidence for c in pair}
    return data, truth, seps, {"top": pair[0].name, "evidence": before, "alternatives": crit.alternatives}


def _new_motions(seps: list[Separation]) -> list[Separation]:
    """The candidates that are no recorded flop again: on a robot resting on a face, flops toward
    headings over the same edge with the same pattern are one motion (their s is the same number),
    and a candidate with a recorded flop's s replays that flop."""
    seen = {s.rms for s in seps if s.recorded}
    return [s for s in seps if not s.recorded and s.rms not in seen]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="sensor_bias")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budget", type=int, default=40)
    ap.add_argument("--add", choices=["best", "least"], default="best")
    ap.add_argument("--journals", default=None, metavar="DIR", help="the first diagnosis's journal folder "
                    "(benchmarks/effects.py names it own-SCENARIO-seedS-actuation-bB-v1 under its --journals)")
    ap.add_argument("--out", default="benchmarks/results/discriminate.jsonl")
    args = ap.parse_args(argv)
    start = time.perf_counter()
    journal = (Path(args.journals) / f"own-{args.scenario}-seed{args.seed}-actuation-b{args.budget}-v1"
               if args.journals else None)
    data, truth, seps, before = contest(args.scenario, args.seed, args.budget, journal)
    for s in seps:
        print(f"{s.label:32s} {1000 * s.rms:8.2f} mm{'  (recorded)' if s.recorded else ''}")
    pick = _new_motions(seps)[0 if args.add == "best" else -1]
    effects = scenario_effects(args.scenario)
    theta = model_space(effects).as_array(truth, check_bounds=False)
    extra = simulate(theta, controller=flop_candidates()[pick.label], duration=1.5, effects=effects, noise=NOISE,
                     seed=[args.seed, 3])
    row = diagnose_row(args.scenario, args.seed, args.budget, [*data, extra], [e.name for e in effects],
                       {}, held_out="actuation", larger=effects[0].name)
    after = {k: v["evidence"] for k, v in row["contenders"].items()}
    print(f"before: top {before['top']}, evidence {before['evidence']}, alternatives {before['alternatives']}")
    print(f"with {pick.label} ({1000 * pick.rms:.2f} mm) fitted too: top {row['top']}, evidence {after}, "
          f"alternatives {row['alternatives']}")
    out = {"scenario": args.scenario, "seed": args.seed, "budget": args.budget, "add": args.add,
           "added": pick.label, "separations": {s.label: s.rms for s in seps}, "before": before,
           "after": {"top": row["top"], "evidence": after, "alternatives": row["alternatives"],
                     "found": row["found"]}, "seconds": time.perf_counter() - start}
    with open(args.out, "a") as f:
        f.write(json.dumps(out) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
