"""What the true effect itself explains on the foreign testbed: a ceiling for any effect search.

benchmarks/effects.py measures whether criticism *finds* a testbed effect hidden in the data. This
script asks how much of the held-out residual the catalog effect could explain at all if the
search knew its true size. Per testbed data set and seed (flops version 2, 0.2 mm noise; fit on
``flop_0`` and ``flop_1``, held out ``heldout_0``, as diagnose splits them):

1. the mismatch stage (criticism.mismatch, journalled under ``--journals``) augments the T6;
2. the base: the augmented model re-tuned on the fit flops (criticism.polish from the stage's θ,
   one least-squares run per fit): E_F, E_H;
3. the truth: the catalog effect that models the hidden one, at the testbed's true size, added
   with its size held and the model's parameters re-tuned on the fit flops (polish over θ only):
   explained_true = 1 - E_H(truth) / E_H(base);
4. the truth let go: the same fit with the effect's size free too, started at the truth:
   explained_free, and where the size went.

Catalog effects in the testbed's terms (benchmarks/testbed/effects.py): ``slope`` -> ground_slope
at the true floor normal; ``actuator_delay`` -> actuator_delay; ``extra_mass`` -> point_mass on
the same rod at the same place; ``ground_viscosity`` -> ground_viscosity at the same coefficient;
``marker_offset`` -> sensor_bias at the offset's z; ``drag`` -> viscous_drag (the testbed's law,
linear in speed) at the same coefficient. Hysteresis is left out: the testbed's softer unloading
has no true size in the catalog's law.

    .venv/bin/python benchmarks/effects_oracle.py --seeds 1                # seed 0, every data set
    .venv/bin/python benchmarks/effects_oracle.py --summarize benchmarks/results/effects-oracle.jsonl
    .venv/bin/python benchmarks/effects_oracle.py --summarize FILE --datasets drag --floor   # noise floors too

``--floor`` adds the held-out error that the data's noise alone leaves (:func:`noise_floor`) and its
share of the base's: about the smallest after / before any model could reach on that flop at that
noise (the floor is computed without the stage's components).

Rows go to ``--out`` (JSON lines); a (data set, seed) already there is skipped.
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
from jsonl_rows import read_rows

from belief.least_squares import LeastSquaresConfig, LocalFit
from criticism import CriticismConfig
from criticism.diagnose import split_masks
from criticism.mismatch import MismatchConfig, MismatchReport
from criticism.search import polish
from criticism.stage_journal import journalled_stage
from physics import ReplayController, TrajectoryObjective, load_trajectory, simulate
from physics.effects import ActuatorDelay, Effect, GroundSlope, GroundViscosity, PointMass, SensorBias, ViscousDrag

NOISE = 0.0002  # [m], the data sets' marker noise

#: Criticism's settings with one least-squares run per fit, the protocol of the saved rows.
ONE_RUN = CriticismConfig(local=LeastSquaresConfig(rounds=1))
DATASETS = ("slope", "actuator_delay", "extra_mass", "ground_viscosity", "marker_offset", "drag")


def true_effect(name: str, seed: int, truth: dict) -> tuple[Effect, dict[str, float]]:
    """The catalog effect behind testbed data set ``name`` and its true parameter values."""
    if name == "slope":
        t, a = truth["slope"], truth["slope_azimuth"]
        return GroundSlope(), {"slope_x": float(np.arcsin(-np.sin(t) * np.cos(a))),
                               "slope_y": float(np.arcsin(-np.sin(t) * np.sin(a)))}
    if name == "actuator_delay":
        return ActuatorDelay(), {"actuator_delay": truth["actuator_delay"]}
    if name == "extra_mass":
        from testbed.datasets import robot_for
        robot = robot_for(name, seed)[0]
        half = 0.5 * robot.theta["rod_length"]
        return (PointMass(rod=robot.effects.extra_mass_rod, position=robot.effects.extra_mass_at / half),
                {"point_mass": truth["extra_mass"]})
    if name == "ground_viscosity":
        return GroundViscosity(), {"ground_viscosity": truth["ground_viscosity"]}
    if name == "marker_offset":
        return SensorBias(), {"sensor_bias_z": truth["marker_offset"][2]}
    if name == "drag":
        return ViscousDrag(), {"viscous_drag": truth["drag"]}
    raise KeyError(f"no catalog truth for testbed data set {name!r}; choose from {DATASETS}.")


@dataclass
class Staged:
    """A testbed data set after the mismatch stage: the objective over its three flops with the fit
    and held-out masks (S,), the stage, the augmented model, its base (re-tuned on the fit flops
    from the stage's θ) and the testbed's true effect sizes."""

    full: TrajectoryObjective
    fit: np.ndarray
    held: np.ndarray
    stage: MismatchReport
    model: TrajectoryObjective
    base: LocalFit
    truth: dict

    def errors(self, parts: np.ndarray) -> tuple[float, float]:
        """E_F, E_H of per-segment errors ``parts`` (S,)."""
        return float(parts[self.fit].sum()), float(parts[self.held].sum())


def staged(name: str, seed: int, journals: Path, config: CriticismConfig) -> Staged:
    """Steps 1 and 2 of the module docstring for data set ``name`` and ``seed``, the stage journalled
    in ``journals``/name-sSEED. The caller closes ``full``."""
    from testbed.datasets import cached_dataset
    files = cached_dataset(name, seed, noise=NOISE, version=2)
    truth = json.loads((files["flop_0"].parent / "truth.json").read_text())["effects"]
    data = [load_trajectory(files[label]) for label in ("flop_0", "flop_1", "heldout_0")]
    full = TrajectoryObjective(data, horizon=25, loss="squared", windows=3)
    try:
        fit, held = split_masks(full.segments, [2])
        stage = journalled_stage(full, fit, [2], config=MismatchConfig(), journal_dir=journals / f"{name}-s{seed}",
                                 progress=False)
        model = full.with_effects(stage.effects)
        return Staged(full, fit, held, stage, model, polish(model, stage.theta, fit, config), truth)
    except BaseException:
        full.close()
        raise


def run_one(name: str, seed: int, journals: Path, config: CriticismConfig) -> dict:
    """The row of one data set and seed (module docstring)."""
    start = time.perf_counter()
    s = staged(name, seed, journals, config)
    try:
        effect, values = true_effect(name, seed, s.truth)
        extended = s.model.with_effects(tuple(s.stage.effects) + (effect,))
        at_truth = np.r_[s.base.theta, [values[p.name] for p in effect.parameters()]]
        D = s.model.space.dim
        held_size = polish(extended, at_truth, s.fit, config, indices=range(D))
        free = polish(extended, held_size.theta, s.fit, config)
    finally:
        s.full.close()
    (bf, bh), (tf, th), (ff, fh) = s.errors(s.base.parts), s.errors(held_size.parts), s.errors(free.parts)
    return {"dataset": name, "seed": seed, "kept": [e.name for e in s.stage.effects], "truth": values,
            "base_fit": bf, "base_held": bh, "true_fit": tf, "true_held": th, "free_fit": ff, "free_held": fh,
            "explained_true": 1 - th / bh, "explained_free": 1 - fh / bh, "fit_gain_true": 1 - tf / bf,
            "free_values": {n: float(v) for n, v in zip(extended.space.names[D:], free.theta[D:], strict=True)},
            "seconds": time.perf_counter() - start}


def noisy_copies(clean: xr.Dataset, draws: int) -> list[xr.Dataset]:
    """``draws`` copies of ``clean`` with N(0, NOISE²) added to the nodes (numpy seed 0) and the
    exact velocities dropped, as a motion-capture recording has none."""
    rng = np.random.default_rng(0)
    copies = []
    for _ in range(draws):
        noisy = clean.drop_vars("velocities", errors="ignore").copy(deep=True)
        noisy["nodes"].values[:] += rng.normal(0.0, NOISE, noisy["nodes"].shape)
        noisy.attrs["noise_m"] = NOISE
        copies.append(noisy)
    return copies


def noise_floor(name: str, seed: int, draws: int = 8) -> float:
    """Mean E_H [m²] that the noise alone leaves on data set ``name``'s held-out flop: DART at the
    testbed robot's θ with the true catalog effect replays the flop's controls (T, C) at its sample
    rate, NOISE is added ``draws`` times, and each copy is scored at that θ with the benchmark's
    objective (horizon 25, three windows). The stage's components are left out, so this is the
    floor of the T6 with the true effect, an approximation of the augmented model's."""
    from testbed.datasets import cached_dataset
    files = cached_dataset(name, seed, noise=NOISE, version=2)
    truth = json.loads((files["flop_0"].parent / "truth.json").read_text())
    effect, values = true_effect(name, seed, truth["effects"])
    held = load_trajectory(files["heldout_0"])
    t = np.asarray(held["time"].values, float)
    replay = ReplayController.of(held)
    theta = {**truth["theta"], **values}
    clean = simulate(theta, controller=replay, duration=float(t[-1] - t[0]), effects=(effect,),
                     sample_rate=1.0 / float(np.median(np.diff(t))))
    with TrajectoryObjective(noisy_copies(clean, draws), horizon=25, loss="squared", windows=3, effects=(effect,),
                             n_workers=0) as E:
        return float(E(E.space.as_array(theta))) / draws


def summarize(rows: list[dict], floor: bool = False) -> None:
    """Print one line per row; with ``floor``, also the noise floor of its held-out flop [m²] and
    its share of the base's held-out error (computed, a few seconds per row)."""
    print(f"{'data set':18s} {'seed':>4} {'fit gain, true size':>20} {'held-out explained, true size':>30} "
          f"{'size free':>10}{'  noise floor / before' if floor else ''}  fitted size (true)")
    for r in rows:
        sizes = ", ".join(f"{k}={v:.4g} ({r['truth'][k]:.4g})" for k, v in r["free_values"].items())
        share = f"  {noise_floor(r['dataset'], r['seed']) / r['base_held']:21.1%}" if floor else ""
        print(f"{r['dataset']:18s} {r['seed']:4d} {r['fit_gain_true']:20.1%} {r['explained_true']:30.1%} "
              f"{r['explained_free']:10.1%}{share}  {sizes}", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--datasets", nargs="*", default=list(DATASETS), choices=DATASETS)
    ap.add_argument("--journals", default=".cache/oracle", help="one folder per data set for the stage's journal")
    ap.add_argument("--out", default="benchmarks/results/effects-oracle.jsonl")
    ap.add_argument("--summarize", default=None, metavar="JSONL", help="only print the table of saved rows")
    ap.add_argument("--floor", action="store_true", help="with --summarize: each row's noise floor (module docstring)")
    args = ap.parse_args(argv)
    if args.summarize:
        summarize([r for r in read_rows(args.summarize) if r["dataset"] in args.datasets], floor=args.floor)
        return 0
    out = Path(args.out)
    saved = read_rows(out)
    done = {(r["dataset"], r["seed"]) for r in saved}
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    for seed in seeds:
        for name in args.datasets:
            if (name, seed) in done:
                continue
            row = run_one(name, seed, Path(args.journals), ONE_RUN)
            saved.append(row)
            with out.open("a") as fh:
                fh.write(json.dumps(row) + "\n")
            print(f"{name} seed {seed}: truth explains {row['explained_true']:.1%} of the held-out error "
                  f"({row['seconds']:.0f} s)", flush=True)
    summarize([r for r in saved if r["seed"] in seeds and r["dataset"] in args.datasets])
    return 0


if __name__ == "__main__":
    sys.exit(main())
