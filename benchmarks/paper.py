"""The paper's comparison (Zhu et al. 2018, Fig. 7 and Table I) on this project's engine, with peers.

    .venv/bin/python benchmarks/paper.py [--truths 3] [--noise 0 0.001] [--budget 60] [--methods ...]
    .venv/bin/python benchmarks/paper.py --summarize benchmarks/results/paper.jsonl
    .venv/bin/python benchmarks/paper.py --smoke --out DIR          # tiny: every method runs and writes

Problems: θ* at nominal and ``--truths`` draws inside the box; observed data are two 1.5 s flops
(headings 0 and 1.05 rad, the default 20 % change of 4 cables) with each ``--noise`` level [m];
the score is E on two *held-out* flops with other actuations (30 % change of 4 cables, 25 % of 6;
a flop toward another heading alone is nearly the same motion rotated) at the best θ so far. Every method gets the same number of
evaluations and is timed, so the held-out error is reported against evaluations and against wall
time (benchmarks/paper_methods.py lists the methods). Trained decoders (VAE, the dynamics-aware
autoencoder without and with its centre prior, the active subspace, and ``ae-cf-5``: the
autoencoder trained through a network on the counterfactual target, what θ changes against the
nominal θ from the same state, embeddings.t6_data) are trained once and cached under
.cache/tensegrid/paper/. Every belief method is a preset of the library (belief.presets, sized by
:class:`Settings`; ``PRESET_OF``): ``random-15`` and ``bo-15`` are ``random`` and ``bo``, ``bo-gn``
adds the finishing Gauss-Newton step, ``rembo-5`` and the trained decoders run ``latent``,
``ae-cf-bo`` is ``handoff`` (``Settings.handoff`` evaluations of BO in ae-cf-5's latent grid, then
BO in the full 15-D space with them as its initial design) and ``ae-cf-bo-gn`` is ``handoff-gn``,
the library's default: the hand-over stopped D + 4 evaluations early, then one Gauss-Newton step
from its best θ, off the candidate grid.

``--source testbed`` takes the problems from the foreign robot (benchmarks/testbed, Bullet): θ* of
its ``nominal`` data set (seed 0) and of ``--truths`` ``perturbed`` ones (seeds 1..), observed
through the flops ``flop_0`` and ``flop_1`` cut to ``Settings.duration``, scored on ``heldout_0``
and ``flop_2``; ``--noise`` sets the data sets' noise. Rows go to ``--out``/testbed/paper.jsonl.

    .venv/bin/python benchmarks/paper.py --source testbed --truths 3 --noise 0.001 --methods bo-15 ae-cf-bo-gn

Each (problem, method) appends one JSON row to ``--out``/paper.jsonl, and a (problem, method) that
already has its row there is skipped, so an interrupted run resumes; ``--summarize`` prints
the tables (held-out error by budget, parameter error in % per parameter, verdicts) and draws
``paper_heldout.png`` next to the rows.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from paper_methods import PEERS, Recorder, run_botorch, run_cma  # noqa: E402
from paper_report import summarize  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TRAINED = ("vae-5", "ae-dyn-5", "ae-dyn-prior-5", "active-5", "ae-cf-5")
METHODS = ("random-15", "bo-15", "bo-gn", "rembo-5", *TRAINED, "ae-cf-bo", "ae-cf-bo-gn", *PEERS)
#: the Settings fields the trained decoders depend on (the cache key)
TRAINING_FIELDS = ("duration", "vae_samples", "vae_epochs", "trajectories", "summary", "dyn_epochs", "ae_epochs",
                   "centre_weight")
# A flop from the resting face goes over one of its three edges, and the face is 3-fold symmetric,
# so flops toward any heading are nearly the same motion rotated (one-step E at a θ differs by
# 1e-5 relative between headings). Held-out flops therefore use other actuations.
FIT_FLOPS = ((0.0, {}), (1.05, {}))
HELD_OUT_FLOPS = ((0.52, {"change": 0.3}), (1.57, {"change": 0.25, "n_cables": 6}))


@dataclass(frozen=True)
class Settings:
    """Sizes of the comparison; ``smoke()`` shrinks every one of them."""

    budget: int = 60
    duration: float = 1.5
    n_init: int | None = None
    points_per_dim: int = 11
    candidates: int = 4096
    vae_samples: int = 20000
    vae_epochs: int = 100
    trajectories: int = 1200
    summary: str = "com"
    dyn_epochs: int = 60
    ae_epochs: int = 60
    centre_weight: float = 0.1
    handoff: int = 15
    workers: int = 2

    @classmethod
    def smoke(cls) -> "Settings":
        return cls(budget=5, duration=0.4, n_init=3, points_per_dim=3, candidates=128, vae_samples=300,
                   vae_epochs=2, trajectories=3, dyn_epochs=2, ae_epochs=2, handoff=3, workers=0)


def observe(space: Any, truth: np.ndarray, flops: tuple, settings: Settings, noise: float, seed: int) -> list[Any]:
    """One simulated trajectory per (heading, FlopController options) in ``flops``."""
    from physics import FlopController, simulate

    return [simulate(truth, controller=FlopController(heading=h, **options), duration=settings.duration,
                     space=space, noise=noise, seed=seed + k if noise > 0 else None)
            for k, (h, options) in enumerate(flops)]


def cache_folder(settings: Settings, cache: Path) -> Path:
    """``cache/paper/<hash of the settings the trained decoders depend on>``."""
    trained_by = {k: v for k, v in asdict(settings).items() if k in TRAINING_FIELDS}
    return cache / "paper" / hashlib.sha256(json.dumps(trained_by, sort_keys=True).encode()).hexdigest()[:12]


def train_decoders(space: Any, settings: Settings, cache: Path, methods: "tuple[str, ...]" = METHODS) -> dict[str, Any]:
    """The trained 5-D decoders ``methods`` need (VAE, the dynamics-aware autoencoder without and with its
    centre prior, the active subspace, ae-cf-5 for the hand-over), each trained once per ``settings``
    and cached under ``cache/paper/<key>/``."""
    from embeddings import VAE, TrainingConfig, load_decoder

    folder = cache_folder(settings, cache)
    folder.mkdir(parents=True, exist_ok=True)
    needed = {m for m in methods if m in TRAINED} | ({"ae-cf-5"} if {"ae-cf-bo", "ae-cf-bo-gn"} & set(methods) else set())
    decoders = {}
    for name in (n for n in TRAINED if n in needed):
        path = folder / f"{name}.json"
        if not path.exists():
            if name == "vae-5":
                decoder = VAE(space, dim=5).fit(settings.vae_samples, training=TrainingConfig(epochs=settings.vae_epochs),
                                                progress=True)
            else:
                decoder = _dynamics_decoder(name, space, settings, cache, folder)
            decoder.save(path)
        decoders[name] = load_decoder(path, space)
    return decoders


def write_pretrained(space: Any, settings: Settings, cache: Path) -> Path:
    """Train (or reuse the cached) ae-cf-5 with ``settings`` and copy it to the library's shipped decoder."""
    from embeddings.pretrained import PRETRAINED_T6, pretrained_path

    train_decoders(space, settings, cache, ("ae-cf-5",))
    target = pretrained_path(PRETRAINED_T6)
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text((cache_folder(settings, cache) / "ae-cf-5.json").read_text())
    print(f"wrote {target}")
    return target


def dynamics_network(space: Any, settings: Settings, cache: Path, folder: Path, *,
                     counterfactual: bool = False) -> tuple[Any, Any, Any]:
    """(network, train, test): the T6 transition set split by trajectory and the network trained on it
    (cached as ``folder/dynamics.json``, or ``dynamics-cf.json`` on the counterfactual target, what θ
    changes against the nominal θ from the same state; its held-out score is printed and kept)."""
    from embeddings import DynamicsNetwork, T6DataConfig, TrainingConfig, t6_transitions

    data = t6_transitions(T6DataConfig(n_trajectories=settings.trajectories, duration=settings.duration,
                                       summary=settings.summary, counterfactual=counterfactual), space=space,
                          cache_dir=cache, workers=settings.workers)
    train, test = data.split(0.2, seed=0)
    tag = "-cf" if counterfactual else ""
    path = folder / f"dynamics{tag}.json"
    if path.exists():
        return DynamicsNetwork.load(path, space), train, test
    dynamics = DynamicsNetwork(space).fit(train, training=TrainingConfig(epochs=settings.dyn_epochs), progress=True)
    score = dynamics.score(test)
    print(f"dynamics network: held-out MSE {score.mse:.3g} vs {score.baseline_mse:.3g} for the mean "
          f"(ratio {score.ratio:.3f}, {len(set(test.group))} held-out trajectories)")
    dynamics.save(path)
    (folder / f"dynamics{tag}_score.json").write_text(json.dumps(asdict(score)))
    return dynamics, train, test


def _dynamics_decoder(name: str, space: Any, settings: Settings, cache: Path, folder: Path) -> Any:
    """The decoder ``name`` trained through the (cached) dynamics network."""
    from embeddings import ActiveSubspace

    dynamics, train, _ = dynamics_network(space, settings, cache, folder, counterfactual=name == "ae-cf-5")
    if name == "active-5":
        active = ActiveSubspace.fit(space, dynamics, train, dim=5)
        print(f"{active!r}")
        return active
    return train_autoencoder(space, dynamics, train, settings,
                             settings.centre_weight if name == "ae-dyn-prior-5" else 0.0)


def train_autoencoder(space: Any, dynamics: Any, train: Any, settings: Settings, centre_weight: float) -> Any:
    """The 5-D DynamicsAutoencoder trained through ``dynamics`` on ``train`` with ``centre_weight``."""
    from embeddings import DynamicsAutoencoder, TrainingConfig

    return DynamicsAutoencoder(space, dim=5, centre_weight=centre_weight).fit(dynamics, train, training=TrainingConfig(
        epochs=settings.ae_epochs, batch_size=128, lr=3e-3), progress=True)


#: paper method -> (preset, decoder the latent stage uses); the other trained decoders run the "latent" preset
PRESET_OF = {"random-15": ("random", None), "bo-15": ("bo", None), "bo-gn": ("bo-gn", None),
             "rembo-5": ("latent", "rembo-5"), "ae-cf-bo": ("handoff", "ae-cf-5"),
             "ae-cf-bo-gn": ("handoff-gn", "ae-cf-5"), **{name: ("latent", name) for name in TRAINED}}


def method_preset(name: str, space: Any, settings: Settings) -> Any:
    """The belief preset that paper method ``name`` runs, sized by ``settings`` (candidates, latent
    evaluations of a hand-over, grid points per latent axis)."""
    from belief.presets import resolve

    preset = resolve(PRESET_OF[name][0])
    return replace(preset, candidates=settings.candidates, points_per_dim=settings.points_per_dim,
                   latent=settings.handoff if preset.latent else 0)


def run_method(name: str, objective: Recorder, space: Any, decoders: dict[str, Any], settings: Settings,
               seed: int) -> Any:
    """Run ``name`` on the recorded objective; returns the identification result (None for peers).

    Belief methods are presets (belief.presets) with this comparison's sizes; the residual
    evaluations of a finishing Gauss-Newton step are logged (``Recorder.count_residuals``), those of
    the verdicts are not."""
    import warnings

    from belief.presets import minimum_budget, reserved_evaluations, run_preset
    from embeddings import REMBO

    if name == "cma-es":
        return run_cma(objective, space, budget=settings.budget, seed=seed)
    if name == "botorch":
        return run_botorch(objective, space, budget=settings.budget, seed=seed, n_init=settings.n_init or 16)
    preset, latent = method_preset(name, space, settings), PRESET_OF[name][1]
    decoder = REMBO(space, dim=5, seed=seed) if latent == "rembo-5" else decoders.get(latent) if latent else None
    verdicts = 0 if preset.local_step else reserved_evaluations(preset, space.dim)   # not logged: outside the budget
    budget = max(settings.budget + verdicts, minimum_budget(preset, space.dim))

    def on_stage(stage: str) -> None:
        objective.count_residuals = stage == "local_step"

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return run_preset(objective, preset, budget=budget, seed=seed, decoder=decoder, n_init=settings.n_init,
                              progress=False, on_stage=on_stage)
    finally:
        objective.count_residuals = False


def score(name: str, log: list, result: Any, held_out: Any, truth: np.ndarray, space: Any) -> dict[str, Any]:
    """The row of one run: held-out E at the best-so-far θ after each evaluation, parameter errors, verdicts."""
    errors = np.array([e for _, e, _ in log])
    times = np.array([t for _, _, t in log])
    cache: dict[bytes, float] = {}
    best, heldout = None, []
    for k, (theta, error, _) in enumerate(log):
        if np.isfinite(error) and (best is None or error < errors[best]):
            best = k
        if best is None:
            heldout.append(float("nan"))
            continue
        key = log[best][0].tobytes()
        if key not in cache:
            try:
                cache[key] = float(held_out(log[best][0]))
            except Exception:
                cache[key] = float("nan")
        heldout.append(cache[key])
    theta = log[best][0] if best is not None else np.full(space.dim, np.nan)
    row = {"method": name, "errors": errors.tolist(), "seconds": times.tolist(), "heldout": heldout,
           "best_theta": theta.tolist(), "truth": truth.tolist(), "names": list(space.names),
           "param_error_pct": (100 * np.abs(theta - truth) / np.abs(truth)).tolist()}
    if result is not None and getattr(result, "marginals", None) is not None:
        m = result.marginals
        row.update(verdict=[str(v) for v in m["verdict"].values], reason=[str(v) for v in m["reason"].values],
                   mean=m["mean"].values.tolist(), lower=m["lower"].values.tolist(), upper=m["upper"].values.tolist(),
                   local_fit=result.belief.attrs.get("local_fit"))
    return row


def _done(path: Path) -> set[tuple]:
    """(truth_kind, truth_index, noise, seed, budget, method) of the rows already in ``path``: a run
    that was interrupted resumes where it stopped."""
    if not path.exists():
        return set()
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return {(r["truth_kind"], r["truth_index"], r["noise"], r["seed"], r["budget"], r["method"]) for r in rows}


def testbed_problem(name: str, index: int, noise: float, settings: Settings) -> tuple[np.ndarray, list, list]:
    """(θ*, fitted flops, held-out flops) of testbed data set ``name`` at seed ``index``, cut to
    ``settings.duration`` seconds."""
    from physics import ParameterSpace, load_trajectory
    from testbed.datasets import cached_dataset

    files = cached_dataset(name, index, noise=noise)
    truth = json.loads((files["flop_0"].parent / "truth.json").read_text())["theta"]

    def load(label: str) -> Any:
        ds = load_trajectory(files[label])
        return ds.sel(time=slice(0.0, settings.duration + 1e-9))

    return (ParameterSpace.t6().as_array(truth), [load("flop_0"), load("flop_1")],
            [load("heldout_0"), load("flop_2")])


def run_problem(space: Any, truth: np.ndarray, noise: float, problem: dict[str, Any], methods: list[str],
                decoders: dict[str, Any], settings: Settings, out: Path, seed: int,
                data: tuple[list, list] | None = None) -> None:
    """Run ``methods`` on one problem (data simulated by this project's model unless ``data`` =
    (fitted, held-out) trajectories are given) and append their rows."""
    from physics import TrajectoryObjective

    done = _done(out / "paper.jsonl")
    key = (problem["truth_kind"], problem["truth_index"], noise, seed, settings.budget)
    methods = [m for m in methods if (*key, m) not in done]
    if not methods:
        return
    fit, held = data or (observe(space, truth, FIT_FLOPS, settings, noise, seed),
                         observe(space, truth, HELD_OUT_FLOPS, settings, noise, seed + 100))
    with TrajectoryObjective(fit, loss="squared", windows=3, n_workers=0) as objective, \
            TrajectoryObjective(held, loss="squared", windows=1, n_workers=0) as held_out:
        for name in methods:
            start = time.perf_counter()
            recorder = Recorder(objective)
            result = run_method(name, recorder, space, decoders, settings, seed)
            row = {**problem, "noise": noise, "seed": seed, "budget": settings.budget,
                   **score(name, recorder.log, result, held_out, truth, space),
                   "wall": time.perf_counter() - start, "heldout_truth": float(held_out(truth))}
            with open(out / "paper.jsonl", "a") as fh:
                fh.write(json.dumps(row) + "\n")
            print(f"{problem['truth_kind']}{problem['truth_index']} noise {noise:g} {name}: best E "
                  f"{np.nanmin(row['errors']):.4g}, held-out {row['heldout'][-1]:.4g}, {row['wall']:.0f} s", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--truths", type=int, default=3, help="truths drawn inside the box (besides nominal)")
    parser.add_argument("--noise", type=float, nargs="+", default=[0.0, 0.001])
    parser.add_argument("--budget", type=int, default=None)
    parser.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--smoke", action="store_true", help="tiny sizes: checks that every method runs")
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "results"))
    parser.add_argument("--cache", default=str(ROOT / ".cache" / "tensegrid"))
    parser.add_argument("--summarize", default=None, help="only print the tables of saved rows (a paper.jsonl)")
    parser.add_argument("--write-pretrained", action="store_true",
                        help="train ae-cf-5 (cached) and write it as the decoder the library ships for the T6's "
                             "default box (embeddings/data/t6-ae-cf-5.json, embeddings.pretrained), then stop")
    parser.add_argument("--source", choices=["own", "testbed"], default="own",
                        help="problems from this project's model (default) or from the foreign testbed (Bullet)")
    args = parser.parse_args()
    if args.summarize:
        summarize(Path(args.summarize), figure=Path(args.summarize).with_name("paper_heldout.png"))
        return
    from physics.parameters import ParameterSpace

    settings = Settings.smoke() if args.smoke else Settings()
    if args.budget:
        settings = Settings(**{**asdict(settings), "budget": args.budget})
    space, out = ParameterSpace.t6(), Path(args.out) / ("testbed" if args.source == "testbed" else "")
    out.mkdir(parents=True, exist_ok=True)
    if args.write_pretrained:
        write_pretrained(space, settings, Path(args.cache))
        return
    decoders = train_decoders(space, settings, Path(args.cache), tuple(args.methods))
    if args.source == "testbed":
        for index in range(0 if args.smoke else args.truths + 1):
            name = "nominal" if index == 0 else "perturbed"
            for noise in args.noise:
                truth, fit, held = testbed_problem(name, index, noise, settings)
                run_problem(space, truth, noise, {"truth_kind": f"testbed-{name}", "truth_index": index},
                            args.methods, decoders, settings, out, args.seed, data=(fit, held))
        summarize(out / "paper.jsonl", figure=out / "paper_heldout.png")
        return
    truths = [("nominal", 0, space.nominal)] + [("box", k + 1, space.sample(1, seed=1000 + k)[0])
                                                for k in range(0 if args.smoke else args.truths)]
    for kind, index, truth in truths:
        for noise in ([0.0] if args.smoke else args.noise):
            run_problem(space, truth, noise, {"truth_kind": kind, "truth_index": index}, args.methods, decoders,
                        settings, out, args.seed)
    summarize(out / "paper.jsonl", figure=out / "paper_heldout.png")


if __name__ == "__main__":
    main()
