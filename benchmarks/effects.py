"""Closing the loop on data with an undeclared effect: is it found, and does adding it help held-out data?

Per scenario and seed: θ* is drawn uniformly from the inner half of the ±10 % box (±5 % of
nominal); three flops (1.5 s, 100 Hz, 0.2 mm sensor noise, headings h0, h0 + 120°, h0 + 240°
with h0 drawn per seed) are simulated with the scenario's effects switched on and not declared;
``criticism.diagnose`` identifies on the first two flops (BO, ``--budget`` evaluations), criticizes
and, when it finds an effect, adds it and re-identifies; the third flop is held out. A flop from
the resting face goes over one of its three edges, so a flop 120° away alone is nearly the same
motion rotated; with ``--held-out actuation`` (the default) the held-out flop also changes 6
cables by 30 % instead of 4 by 20 %, ``--held-out heading`` keeps the first protocol.

Scenarios: one per catalog effect at the size in effects_table.SIZES; ``point_mass_elsewhere`` (the mass on
rod 3 at −0.6 of its half length, where the catalog's own instance is not: its place is searched,
PointMass.placements); ``none`` (no extra effect);
``outside`` (a mis-zeroed encoder on one cable, physics.effects.EncoderOffset, not in the
catalog); ``mix`` (ground slope and actuator delay); ``actuator+contact`` (rate-limited actuator
and end-cap radius, as another engine's SUPERball differs from this one).

Printed per scenario: seeds; how often the true effect (of a mix, the larger one: the one whose
omission raises the held-out error at the true parameters most) is ranked first (or measured at
rest and added before the search, criticism.diagnose.shown_at_rest: it is then found too), is
ranked first or named as an alternative the data cannot tell from the found one, and is found; how often any
effect is claimed; the median held-out explained fraction of the top effect; the median (and
largest) held-out error after / before adding the found effect(s); the median estimated size
against the true one; for mixes how often the second effect is found on pass 2.

    .venv/bin/python benchmarks/effects.py                          # every scenario, 10 seeds
    .venv/bin/python benchmarks/effects.py --seeds 2 --scenarios actuator_delay none
    .venv/bin/python benchmarks/effects.py --summarize benchmarks/results/effects-actuation.jsonl  # the table again

``--source testbed`` runs the same protocol on the foreign robot (benchmarks/testbed, Bullet): its
data sets ``nominal`` (scenario ``none``), ``slope``, ``marker_offset``, ``drag``,
``actuator_delay``, ``hysteresis``, ``extra_mass`` and ``ground_viscosity``, and the pairs
``slope+delay`` and ``drag+hysteresis`` (two passes), at nominal θ, with 0.2 mm noise and 3 s
flops: diagnose identifies on ``flop_0`` and ``flop_1`` and holds out ``heldout_0`` (another
actuation). The true effect counts as found when the catalog effect that models it
(TESTBED_TRUTH) is; rows go to benchmarks/results/effects-testbed.jsonl and record each pass's
finding under ``passes``.

    .venv/bin/python benchmarks/effects.py --source testbed --seeds 2
    .venv/bin/python benchmarks/effects.py --source testbed --mismatch --seeds 1   # mismatch stage first
    .venv/bin/python benchmarks/effects.py --source testbed --mismatch --flops-version 2 --seeds 1 \
        --out benchmarks/results/effects-testbed-mismatch-flops2.jsonl           # flops new to every seed

``--source mujoco-native`` runs it on the robot rebuilt with MuJoCo's own tendons and winches
(testbed.mujoco_native; no drag, hysteresis or ground viscosity data sets).
``--source mujoco`` runs it on the same robots and flops in MuJoCo (testbed.mujoco_robot, the third
engine; rows record ``engine``).

``--mismatch`` runs diagnose's mismatch stage (criticism.mismatch, diagnose's default; off here
unless asked, so that rows compare with the tables measured before the stage) before the first identification,
so effects are searched on the model it augments; rows record the components it kept and its
held-out ratios, and go to a file of their own (``...-mismatch.jsonl``).

Runs go seed by seed over the scenarios; a (scenario, seed, --held-out, --budget) already in
``--out`` is skipped, so an interrupted run resumes and a rerun prints the table of its rows.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr
from effects_table import SIZES, print_rows, summarize
from jsonl_rows import read_rows

from belief.least_squares import LeastSquaresConfig
from criticism import CriticismConfig, DiagnoseConfig, Pass, diagnose
from criticism.mismatch import MismatchConfig
from physics import FlopController, ParameterSpace, TrajectoryObjective, load_trajectory, simulate
from physics.effects import EFFECT_TYPES, EncoderOffset, PointMass, catalog, model_space

#: Criticism's default number of least-squares runs per refinement (CriticismConfig.local).
DEFAULT_ROUNDS = CriticismConfig().local.rounds
#: How many ranked effects get a second look at the stage by default (DiagnoseConfig.suspects).
DEFAULT_SUSPECTS = DiagnoseConfig().suspects


@dataclass(frozen=True)
class Loop:
    """The loop's settings a row records beside its protocol: criticism's least-squares ``rounds``
    and ``patience`` (belief.least_squares.LeastSquaresConfig) and how many ranked effects get a
    second look at the stage (``suspects``, criticism.revisit)."""

    rounds: int = DEFAULT_ROUNDS
    patience: int = 1
    suspects: int = DEFAULT_SUSPECTS

    def record(self) -> dict:
        """The row's fields (patience and suspects only when not 1: rows saved before either field
        was recorded were made with 1)."""
        return {"rounds": self.rounds, **({"patience": self.patience} if self.patience != 1 else {}),
                **({"suspects": self.suspects} if self.suspects != 1 else {})}


MIXES = {"mix": ("ground_slope", "actuator_delay"), "actuator+contact": ("rate_limited_actuator", "end_cap_radius")}
#: scenarios whose effect sits where the catalog's default instance does not: the search must find its place
PLACED = {"point_mass_elsewhere": PointMass(rod=3, position=-0.6)}
#: testbed data set -> the catalog effects that model its hidden effects (a mix has two)
TESTBED_TRUTH: dict[str, tuple[str, ...]] = {
    "nominal": (), "slope": ("ground_slope",), "marker_offset": ("sensor_bias",), "drag": ("viscous_drag",),
    "actuator_delay": ("actuator_delay",), "hysteresis": ("cable_hysteresis",), "extra_mass": ("point_mass",),
    "ground_viscosity": ("ground_viscosity",), "slope+delay": ("ground_slope", "actuator_delay"),
    "drag+hysteresis": ("viscous_drag", "cable_hysteresis")}
#: the testbed's effect field behind each catalog effect of a testbed mix (to switch it off)
TESTBED_FIELDS = {"ground_slope": ("slope",), "actuator_delay": ("actuator_delay",), "viscous_drag": ("drag",),
                  "cable_hysteresis": ("hysteresis",)}
#: --source of a foreign robot -> its engine (testbed.datasets.ENGINES)
FOREIGN = {"testbed": "bullet", "mujoco": "mujoco", "mujoco-native": "mujoco-native"}


def scenario_effects(name: str) -> list:
    """The effect instances a scenario's data carry (the first is the larger one of a mix)."""
    if name == "none":
        return []
    if name == "outside":
        return [EncoderOffset()]
    if name in PLACED:
        return [PLACED[name]]
    names = MIXES.get(name, (name,))
    return [EFFECT_TYPES[n]() for n in names]


#: FlopController options of the held-out (third) flop, by ``--held-out``
HELD_OUT = {"actuation": {"change": 0.3, "n_cables": 6}, "heading": {}}


def make_data(name: str, seed: int, *, duration: float = 1.5, noise: float = 0.0002,
              held_out: str = "actuation") -> tuple[list, dict]:
    """Three flops with the scenario's effects (the third per ``HELD_OUT[held_out]``); returns them
    and the true values of all parameters."""
    effects = scenario_effects(name)
    rng = np.random.default_rng([seed, 8])
    base = ParameterSpace.t6()
    truth = dict(zip(base.names, base.nominal * (1 + rng.uniform(-0.05, 0.05, base.dim)), strict=True))
    for e in effects:
        truth.update(SIZES[e.name])
    theta = model_space(effects).as_array(truth, check_bounds=False)
    h0 = float(rng.uniform(0, 2 * np.pi))
    options = [{}, {}, HELD_OUT[held_out]]
    data = [simulate(theta, controller=FlopController(h0 + k * 2 * np.pi / 3, **options[k]), duration=duration,
                     effects=effects, noise=noise, seed=[seed, k]) for k in range(3)]
    return data, truth


def larger_effect(name: str, data: list, truth: dict) -> str:
    """Of a mix, the effect whose omission raises the held-out error at the true parameters most."""
    effects = scenario_effects(name)
    costs = {}
    for missing in effects:
        kept = [e for e in effects if e is not missing]
        objective = TrajectoryObjective(data[2], horizon=25, loss="squared", effects=kept, n_workers=0)
        space = model_space(kept)
        costs[missing.name] = objective(space.as_array({n: v for n, v in truth.items() if n in space.names},
                                                       check_bounds=False))
    return max(costs, key=costs.get)


def testbed_data(name: str, seed: int, flops_version: int = 1, engine: str = "bullet") -> tuple[list, list[str], dict]:
    """Testbed data set ``name`` at ``seed`` (0.2 mm noise; its flops' version and engine, testbed.datasets):
    two flops and the held-out flop, the catalog effects that model its hidden ones (of a mix, the
    larger first) and their true values."""
    from testbed.datasets import cached_dataset
    files = cached_dataset(name, seed, noise=0.0002, version=flops_version, engine=engine)
    truth = json.loads((files["flop_0"].parent / "truth.json").read_text())
    data = [load_trajectory(files[label]) for label in ("flop_0", "flop_1", "heldout_0")]
    names = list(TESTBED_TRUTH[name])
    if len(names) > 1:
        larger = testbed_larger(name, seed, data[2], names, flops_version, engine)
        names = [larger] + [n for n in names if n != larger]
    return data, names, truth["effects"]


def testbed_larger(name: str, seed: int, held: xr.Dataset, names: list[str], flops_version: int = 1,
                   engine: str = "bullet") -> str:
    """Of a testbed mix, the catalog effect whose hidden counterpart, switched off in the testbed,
    moves the noise-free held-out flop furthest from the data (RMS over nodes and samples)."""
    import tempfile
    from dataclasses import replace

    from testbed.datasets import make_dataset, robot_for
    from testbed.record import Observation
    effects = robot_for(name, seed)[0].effects
    observed = held["nodes"].values
    costs = {}
    for effect in names:
        off = replace(effects, **{f: 0.0 for f in TESTBED_FIELDS[effect]})
        with tempfile.TemporaryDirectory() as tmp:
            make_dataset(name, seed, tmp, effects=off, obs=Observation(noise=0.0), version=flops_version,
                         engine=engine)
            without = load_trajectory(Path(tmp) / "heldout_0.nc")["nodes"].values
        costs[effect] = float(np.sqrt(np.nanmean((without - observed) ** 2)))
    return max(costs, key=costs.get)


def run_one(name: str, seed: int, budget: int, held_out: str = "actuation", source: str = "own",
            mismatch: bool = False, flops_version: int = 1, read_contact: bool = False,
            journals: Path | None = None, loop: Loop = Loop()) -> dict:
    """The row of one scenario and seed; diagnose journals its stage and evaluations in a folder of
    ``journals`` named after the run (None: not journalled); ``loop``: the loop's settings (:class:`Loop`)."""
    run = (f"{source}-{name}-seed{seed}-{held_out}-b{budget}-v{flops_version}{'-mismatch' if mismatch else ''}"
           f"{'-contact' if read_contact else ''}")
    folder = None if journals is None else journals / run
    if source in FOREIGN:
        data, truth_names, true_values = testbed_data(name, seed, flops_version, FOREIGN[source])
        row = diagnose_row(name, seed, budget, data, truth_names, true_values, held_out="testbed",
                           larger=truth_names[0] if truth_names else None, mismatch=mismatch,
                           passes=max(1, len(truth_names)), read_contact=read_contact, journal_dir=folder,
                           loop=loop)
        return {**row, "flops_version": flops_version,
                **({"engine": FOREIGN[source]} if source != "testbed" else {})}
    effects = scenario_effects(name)
    data, truth = make_data(name, seed, held_out=held_out)
    larger = larger_effect(name, data, truth) if name in MIXES else (effects[0].name if effects else None)
    row = diagnose_row(name, seed, budget, data, [e.name for e in effects],
                       {k: v for e in effects for k, v in SIZES[e.name].items()}, held_out=held_out, larger=larger,
                       mismatch=mismatch, read_contact=read_contact, journal_dir=folder, loop=loop)
    return {**row, "true_configs": [e.config() for e in effects], "theta_true": truth}


def diagnose_config(budget: int, passes: int, seed: int, *, mismatch: bool = False, read_contact: bool = False,
                    loop: Loop = Loop()) -> DiagnoseConfig:
    """The benchmark's diagnose settings: the library's defaults but for these."""
    return DiagnoseConfig(budget=budget, passes=passes, seed=seed, mismatch=MismatchConfig() if mismatch else None,
                          read_contact=read_contact, suspects=loop.suspects,
                          criticism=CriticismConfig(local=LeastSquaresConfig(rounds=loop.rounds,
                                                                             patience=loop.patience)))


def diagnose_row(name: str, seed: int, budget: int, data: list, truth: list[str], true_values: dict, *,
                 held_out: str, larger: str | None, mismatch: bool = False, passes: int | None = None,
                 read_contact: bool = False, journal_dir: Path | None = None, loop: Loop = Loop()) -> dict:
    """Diagnose on data[0:2], hold out data[2] (with the mismatch stage first if ``mismatch``, the
    contact read from the flops first if ``read_contact``) in ``passes`` passes (default: 2 for a
    mix, else 1); the benchmark's row (JSON-ready)."""
    passes = passes or (2 if name in MIXES else 1)
    start = time.perf_counter()
    config = diagnose_config(budget, passes, seed, mismatch=mismatch, read_contact=read_contact, loop=loop)
    d = diagnose(data, held_out=[2], config=config, progress=False, journal_dir=journal_dir)
    first, names = d.passes[0].criticism, d.passes[0].names
    top = first.ranking[0] if first.ranking else None
    row = {"scenario": name, "seed": seed, "truth": truth, "top": top.name if top else None,
           "top_explained": top.explained if top else None, "top_values": top.values if top else None,
           "top_evidence": top.evidence if top else None, "top_config": top.config if top else None,
           "top_placements": top.placements if top else None,
           "floor": first.floor.name,
           "floor_explained": first.floor.explained, "floor_evidence": first.floor.evidence,
           "n_eff_held": first.n_eff_held, "top_n_eff": (top.n_fit + top.n_held) if top else None,
           "n_eff_fit": first.n_eff_fit,
           "found": d.found, "measured": [e.name for e in d.measured], "alternatives": first.alternatives,
           "replication": first.replication,
           "contenders": {c.name: {"evidence": c.evidence, "fit_error": c.fit_error, "held_error": c.held_error,
                                   "theta": dict(zip(names, c.theta[:len(names)], strict=True))}
                          for c in first.ranking if c.name in (first.contest or {}).get("effects", [])},
           "theta_retuned": dict(zip(names, first.theta.tolist(), strict=True)),
           "reductions": [p.reduction for p in d.passes if p.reduction is not None],
           "held_before": sum(d.passes[0].held_before.values()), "seconds": time.perf_counter() - start,
           "true_values": true_values, "held_out": held_out, "larger": larger, "mismatch": mismatch,
           "estimates": d.passes[0].estimates(),
           "stage": None if d.mismatch is None else {"kept": [e.name for e in d.mismatch.effects],
                                                     "ratios": d.mismatch.ratios()},
           "read_contact": read_contact, **loop.record(),
           "contact": None if d.contact is None else d.contact.as_dict(),
           "revisits": [look.as_dict() for p in d.passes for look in p.looks],
           "passes": [_pass_record(p) for p in d.passes]}
    last = [p for p in d.passes if p.held_after is not None]
    row["held_after"] = sum(last[-1].held_after.values()) if last else None
    return row


def _pass_record(p: Pass) -> dict:
    """One pass of a diagnosis: the effect it found (None), with the share of the held-out error it
    explained, its evidence and fitted values, the held-out reduction after re-identifying with it
    and its re-identified estimates; the pass's ranking as [effect, explained, evidence] rows."""
    found = p.found
    return {"found": found.name if found else None, "explained": found.explained if found else None,
            "evidence": found.evidence if found else None, "values": found.values if found else None,
            "reduction": p.reduction, "estimates": p.estimates() if found else {},
            "ranking": [[c.name, c.explained, c.evidence] for c in p.criticism.ranking]}


def _key(row: dict) -> tuple:
    """A run's identity: data set, seed and protocol (held-out flop, budget, flops version, contact
    read, engine, least-squares rounds: 1 in rows saved before they were recorded, patience and
    suspects)."""
    return (row["scenario"], row["seed"], row.get("held_out", "heading"), row.get("budget"),
            row.get("flops_version", 1), row.get("read_contact", False), row.get("engine", "bullet"),
            row.get("rounds", 1), row.get("patience", 1), row.get("suspects", 1))


def latest_rows(rows: list[dict], per_seed: bool = False) -> list[dict]:
    """Of rows with the same :func:`_key` (per_seed: the same data set and seed, whatever the
    protocol), the last one, at the place of the first."""
    key = (lambda r: (r["scenario"], r["seed"])) if per_seed else _key
    return list({key(r): r for r in rows}.values())


def _parser() -> argparse.ArgumentParser:
    """The command line of the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0, help="seeds first-seed .. first-seed + seeds - 1")
    ap.add_argument("--summarize", nargs="+", default=None, metavar="JSONL",
                    help="only print the table of saved rows (of several files: their rows in order)")
    ap.add_argument("--latest", action="store_true", help="with --summarize: only the latest row of each "
                    "data set, seed and protocol (a later file's row replaces an earlier one)")
    ap.add_argument("--per-seed", action="store_true", help="with --latest: the latest row of each data set and "
                    "seed whatever its protocol (files given in the order the default changed give its standing)")
    ap.add_argument("--rows", action="store_true", help="with --summarize: also one line per row (held-out errors)")
    ap.add_argument("--budget", type=int, default=40)
    ap.add_argument("--held-out", choices=sorted(HELD_OUT), default="actuation",
                    help="the held-out flop: another actuation (default) or only another heading")
    ap.add_argument("--source", choices=["own", *FOREIGN], default="own",
                    help="data from this project's model (default), the foreign testbed (Bullet) or the same "
                         "robot in MuJoCo (the third engine)")
    ap.add_argument("--scenarios", nargs="*", default=None,
                    help="default: every catalog effect, none, outside, mix, actuator+contact (own); every "
                    "testbed data set (testbed)")
    ap.add_argument("--mismatch", action="store_true", help="run diagnose's mismatch stage first")
    ap.add_argument("--read-contact", action="store_true", help="read the contact law from the flops first "
                    "(criticism.contact; testbed data; give such runs their own --out)")
    ap.add_argument("--flops-version", type=int, default=1, help="of the testbed's flops (testbed.datasets: "
                    "2 draws each flop's actuation from the seed; give such runs their own --out)")
    ap.add_argument("--journals", default=None, metavar="DIR",
                    help="journal each run's diagnosis under DIR (a rerun with another criticism reuses its mismatch "
                         "stage and first identification; a journal of another problem is an error)")
    ap.add_argument("--rounds", type=int, default=DEFAULT_ROUNDS, help="most runs of each of criticism's "
                    f"least-squares refinements (belief.least_squares; default {DEFAULT_ROUNDS}, CriticismConfig's; "
                    "rows without a rounds field made one)")
    ap.add_argument("--patience", type=int, default=1, help="stop those refinements after this many runs in a "
                    "row that each lowered the fit error by under 1 %% (LeastSquaresConfig.patience; default 1)")
    ap.add_argument("--suspects", type=int, default=DEFAULT_SUSPECTS, help="how many of the ranking's best "
                    "effects get a second look at the stage when none is found (DiagnoseConfig.suspects; default "
                    "%(default)s; rows without a suspects field made 1)")
    ap.add_argument("--out", default=None, help="rows are appended here (JSON lines; default "
                    "benchmarks/results/effects-{held-out}[-mismatch].jsonl)")
    return ap


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.summarize:
        saved = [r for path in args.summarize for r in read_rows(path)]
        saved = latest_rows(saved, args.per_seed) if args.latest else saved
        summarize(saved)
        if args.rows:
            print_rows(saved)
        return 0
    if args.scenarios is None:
        args.scenarios = (list(TESTBED_TRUTH) if args.source in FOREIGN
                          else [e.name for e in catalog()] + [*PLACED, "none", "outside", "mix", "actuator+contact"])
    if args.source in FOREIGN:
        args.held_out = "testbed"
    out = Path(args.out or f"benchmarks/results/effects-{args.held_out}{'-mismatch' if args.mismatch else ''}.jsonl")
    out.parent.mkdir(parents=True, exist_ok=True)
    saved = read_rows(out)
    done = {_key(r) for r in saved}
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    loop = Loop(args.rounds, args.patience, args.suspects)
    protocol = _key({"scenario": None, "seed": None, "held_out": args.held_out, "budget": args.budget,
                     "flops_version": args.flops_version, "read_contact": args.read_contact,
                     "engine": FOREIGN.get(args.source, "bullet"), **loop.record()})[2:]
    rows = [r for r in saved if r["scenario"] in args.scenarios and r["seed"] in seeds and _key(r)[2:] == protocol]
    for seed in seeds:                  # seed by seed: a partial run covers every scenario
        for name in args.scenarios:
            if (name, seed, *protocol) in done:
                continue
            row = {**run_one(name, seed, args.budget, args.held_out, args.source, args.mismatch, args.flops_version,
                             args.read_contact, Path(args.journals) if args.journals else None, loop),
                   "budget": args.budget}
            rows.append(row)
            with out.open("a") as fh:
                fh.write(json.dumps(row) + "\n")
            print(f"{name} seed {seed}: top {row['top']}, found {row['found']}, {row['seconds']:.0f} s", flush=True)
    summarize(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
