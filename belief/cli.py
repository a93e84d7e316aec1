"""``tensegrid identify``: the command-line layer over :func:`belief.presets.run_preset`.

::

    tensegrid identify DATA.nc [MORE.nc ...] [--preset handoff-gn] --budget N --out DIR
    tensegrid identify DATA.nc --preset latent --decoder ae-dyn --decoder-file ae.json --budget N --out DIR
    tensegrid identify --toy push --preset bo --budget 30 --out DIR

``--preset`` names the recipe (belief.presets): ``handoff-gn`` (default, the best measured) spends
``--latent`` evaluations of BO in a learned 5-D latent grid, continues BO in the full space over
``--candidates`` Sobol points with them as its initial design, and finishes with one
Gauss-Newton step (D + 4 evaluations, counted in ``--budget``); ``handoff`` stops before the
step; ``bo-gn``/``bo`` search the full space only, ``random`` is random search there, and
``latent`` searches only the latent grid. The latent decoder is the one shipped for the T6's
default box, or ``--decoder rembo`` (a random embedding of dimension ``--dim``) or a trained
decoder (``vae``, ``ae-dyn``, ``active``: ``--decoder-file FILE`` written by ``tensegrid
train-embedding`` or ``decoder.save``). Several data files make one objective: E(θ) sums the
one-step errors of all trajectories, each split into ``--windows`` segments.

Writes ``DIR/result.nc`` (see ``IdentificationResult.save``), ``summary.txt`` and
``marginals.csv``, ``history.csv``, ``error_vs_evaluations.png``, ``posterior_marginals.png``
(and ``posterior_2d.png`` for 2-D grids, ``observed_vs_predicted.png`` with rollouts at the
nominal, best and posterior-mean θ of the first trajectory for trajectory data), and journals to
``DIR/journal.sqlite`` (the latent stage to ``DIR/journal-latent.sqlite``) so an interrupted run
resumes when re-run. When the data files carry the θ that generated them (simulated data do),
the summary shows it next to P's intervals. The data files are checked first as by ``tensegrid check``
(docs/data-format.md): an error stops the run before any evaluation, unless ``--skip-checks``.
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Any

from belief.presets import DEFAULT_PRESET, PRESETS

__all__ = ["register_identify", "run_identify"]


def register_identify(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add the ``identify`` sub-command to a ``tensegrid`` argparse sub-parser collection."""
    p = subparsers.add_parser(
        "identify", help="identify physical parameters from a trajectory (Bayesian optimization, posterior P)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("data", nargs="*", default=[],
                   help="observed trajectories (netCDF, docs/data-format.md); several files make one error E(θ)")
    p.add_argument("--toy", choices=["push"], help="use the 1-D push toy instead of data (no physics engine)")
    p.add_argument("--preset", choices=list(PRESETS), default=DEFAULT_PRESET,
                   help=f"identification recipe (belief.presets; default {DEFAULT_PRESET}, the best measured)")
    p.add_argument("--decoder", choices=["rembo", "vae", "ae-dyn", "active"], default=None,
                   help="latent decoder of the presets with a latent stage (default: the one shipped for the T6's "
                        "default box)")
    p.add_argument("--decoder-file", default=None,
                   help="a decoder file: `tensegrid train-embedding` writes vae and ae-dyn, "
                        "ActiveSubspace.save writes active (needed by those three)")
    p.add_argument("--latent", type=int, default=None, metavar="N",
                   help="evaluations of the latent stage of the handoff presets (default 15)")
    p.add_argument("--budget", type=int, default=50, help="number of evaluations of E (default 50)")
    p.add_argument("--time-budget", type=float, default=None, help="wall-clock budget in seconds")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--dim", type=int, default=5, help="--decoder rembo: latent dimension (default 5, capped at D)")
    p.add_argument("--points-per-dim", type=int, default=None,
                   help="grid nodes per latent axis, and per axis of a full space of D <= 4 (default 11)")
    p.add_argument("--candidates", type=int, default=4096, help="Sobol candidates of the full-space search, D > 4")
    p.add_argument("--q", type=int, default=1, help="evaluations per batch (parallel)")
    p.add_argument("--workers", type=int, default=1,
                   help="parallel evaluations of a batch (T6: dask worker processes; 1 = serial)")
    p.add_argument("--posterior", choices=["likelihood", "minimizer"], default="likelihood")
    p.add_argument("--loss", choices=["squared", "norm"], default="squared",
                   help="T6 error: sum of squared residuals (default; what the likelihood posterior assumes) "
                        "or of norms")
    p.add_argument("--windows", type=int, default=3,
                   help="T6 error: contiguous segments per trajectory whose errors sum to E (default 3)")
    p.add_argument("--noise-var", type=float, default=None, help="sigma^2 of the likelihood posterior (units of E)")
    p.add_argument("--noise-rule", choices=["ess", "iid"], default="ess",
                   help="sigma^2 when not given: 'ess' (effective residual count and discrepancy, default) or 'iid' "
                        "(E_min / (K - d), for comparison); docs/identification.md")
    p.add_argument("--discrepancy", type=float, default=0.05,
                   help="ess rule: relative excess error that costs one nat at least (default 0.05)")
    p.add_argument("--journal", default=None, help="SQLite journal (default OUT/journal.sqlite); 'none' disables")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.add_argument("--skip-checks", action="store_true",
                   help="do not stop on the data checks' errors (tensegrid check; docs/data-format.md)")
    p.set_defaults(func=run_identify)


def _push_objective(seed: int) -> tuple[Any, Any]:
    import numpy as np

    from physics.push import PushObjective, generate_push_data, push_space

    space = push_space()
    truth = np.array([1.0, 0.4])
    impulses, observed = generate_push_data(truth, n=8, noise_std=0.05, seed=seed)
    return PushObjective(impulses, observed, space=space, noise_std=0.05), truth


def _plot_rollouts(dataset: Any, space: Any, result: Any, path: str, *, title: str = "") -> None:
    """Observed centre of mass vs open-loop rollouts at the nominal, best and posterior-mean θ, for one trajectory."""
    from physics.errors import PhysicsError
    from physics.plotting import plot_observed_vs_predicted
    from physics.trajectory_objective import TrajectoryObjective

    thetas = {"nominal": space.nominal, "best": result.best_theta.values,
              "posterior mean": result.marginals["mean"].values}
    preds = {}
    with TrajectoryObjective([dataset], horizon="rollout", n_workers=0) as roll:
        for name, th in thetas.items():
            try:
                preds[name] = roll.predictions(th)[0]
            except PhysicsError as exc:  # a rollout may diverge; say so and draw the others
                print(f"tensegrid identify: rollout at the {name} theta diverged ({exc}); not drawn", file=sys.stderr)
    if preds:
        plot_observed_vs_predicted(dataset, preds, path, title=title or "observed vs rollout predictions")


def _data_truth(datasets: list[Any], space: Any) -> Any:
    """θ that generated the data (the files' ``theta`` variable), if every file carries the same one."""
    import numpy as np

    thetas = [ds["theta"] for ds in datasets if "theta" in ds]
    if not datasets or len(thetas) != len(datasets):
        return None
    try:
        first = np.asarray(thetas[0].sel(parameter=list(space.names)).values, dtype=float)
    except (KeyError, ValueError):
        return None
    same = all(np.allclose(t.sel(parameter=list(space.names)).values, first) for t in thetas[1:])
    return first if same else None


def _objective(args: argparse.Namespace) -> tuple[Any, Any, list[Any]]:
    """(objective, true θ or None, datasets) from the data files or the toy."""
    if args.toy == "push":
        objective, truth = _push_objective(args.seed)
        return objective, truth, []
    from physics.trajectory import load_trajectory
    from physics.trajectory_objective import TrajectoryObjective

    datasets = [load_trajectory(path) for path in args.data]
    if not getattr(args, "skip_checks", False):
        from physics.cli_check import preflight

        preflight(datasets, args.data, "identify")          # raises DataCheckError before any evaluation
    objective = TrajectoryObjective(datasets, horizon=1, loss=args.loss, windows=args.windows,
                                n_workers=args.workers if args.workers > 1 else 0)
    return objective, _data_truth(datasets, objective.space), datasets


def _latent_decoder(args: argparse.Namespace, space: Any) -> Any:
    """The latent decoder named on the command line, or None (the preset's default)."""
    from embeddings import REMBO, load_decoder
    from embeddings.errors import EmbeddingError

    if args.decoder is None:
        if args.decoder_file:
            raise EmbeddingError("--decoder-file needs --decoder vae, ae-dyn or active (the kind the file holds).")
        return None
    if args.decoder == "rembo":
        if args.decoder_file:
            raise EmbeddingError("--decoder-file is for trained decoders (vae, ae-dyn, active), not --decoder rembo.")
        return REMBO(space, dim=min(args.dim, space.dim), seed=args.seed)
    if not args.decoder_file:
        how = ("ActiveSubspace.fit(...).save(FILE)" if args.decoder == "active"
               else f"`tensegrid train-embedding {args.decoder} --out FILE`")
        raise EmbeddingError(f"--decoder {args.decoder} needs --decoder-file FILE; write one with {how}.")
    decoder = load_decoder(args.decoder_file, space)
    kind = decoder.config()["kind"]
    if kind != args.decoder:
        raise EmbeddingError(f"{args.decoder_file} holds a {kind} decoder, not {args.decoder}; pass --decoder {kind}.")
    return decoder


def _preset(args: argparse.Namespace) -> Any:
    """The preset named by --preset, sized by --latent, --candidates and --points-per-dim."""
    from dataclasses import replace

    from belief.errors import BudgetError

    preset = PRESETS[args.preset]
    if args.latent is not None:
        if preset.latent == 0:
            raise BudgetError(f"--latent sizes the latent stage of the handoff presets; --preset {args.preset} has "
                              "none. Drop --latent or pass --preset handoff-gn/handoff.")
        if args.latent < 1:
            raise BudgetError(f"--latent must be at least 1 evaluation, got {args.latent}.")
        preset = replace(preset, latent=args.latent)
    return replace(preset, candidates=args.candidates, points_per_dim=args.points_per_dim or 11)


def _run(args: argparse.Namespace, objective: Any) -> tuple[Any, Any, Any]:
    """(result, decoder, grid of P) of the preset with the command line's options; a budget warning goes
    into the summary, not stderr."""
    import warnings

    from belief.errors import BeliefError, BudgetWarning
    from belief.posterior import PosteriorConfig
    from belief.presets import PresetWarning, run_preset

    journal: str | None = args.journal or os.path.join(args.out, "journal.sqlite")
    if journal is not None and journal.lower() == "none":
        journal = None
    config = PosteriorConfig(mode=args.posterior, noise_var=args.noise_var, noise_rule=args.noise_rule,
                             discrepancy=args.discrepancy)
    decoder = _latent_decoder(args, objective.space)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("ignore", BudgetWarning)      # the summary prints it
        warnings.simplefilter("always", PresetWarning)
        result = run_preset(objective, _preset(args), budget=args.budget, seed=args.seed, decoder=decoder,
                            journal=journal, posterior_config=config, time_budget=args.time_budget, q=args.q,
                            workers=args.workers, progress=not args.no_progress)
    for note in caught:
        print(f"tensegrid identify: note: {note.message}", file=sys.stderr)
    if result.belief is None:       # run_preset builds one whenever a posterior mode is set, as here
        raise BeliefError("the identification returned no belief; the command line needs its posterior.")
    return result, result.belief.decoder(), result.belief.grid()


def _write(args: argparse.Namespace, result: Any, decoder: Any, grid: Any, truth: Any, datasets: list[Any]) -> None:
    """result.nc, summary.txt, marginals.csv, history.csv and the figures into ``args.out``."""
    import numpy as np
    import pandas as pd

    from belief.plots import plot_error_trace, plot_marginals, plot_posterior_2d

    out, space = args.out, decoder.space
    result.save(os.path.join(out, "result.nc"))
    with open(os.path.join(out, "summary.txt"), "w") as fh:
        fh.write(result.summary(truth=truth) + "\n")
    result.marginals.to_dataframe().to_csv(os.path.join(out, "marginals.csv"))
    h = result.history
    hist_tab = {"evaluation": h["evaluation"].values, "error": h["error"].values, "seconds": h["seconds"].values,
                "status": h["status"].values}
    hist_tab.update({name: h["theta"].values[:, j] for j, name in enumerate(space.names)})
    pd.DataFrame(hist_tab).to_csv(os.path.join(out, "history.csv"), index=False)
    plot_error_trace(result, os.path.join(out, "error_vs_evaluations.png"), label=f"best so far ({args.preset})")
    plot_marginals(result.posterior, decoder.decode(np.asarray(grid.points)), space,
                   os.path.join(out, "posterior_marginals.png"), marginals=result.marginals, truth=truth)
    if result.posterior.ndim == 2 and result.posterior.dims == ("z0", "z1"):
        plot_posterior_2d(result.posterior, os.path.join(out, "posterior_2d.png"), decoder=decoder,
                          evaluated=h["z"].values, truth=truth)
    if datasets:
        title = (f"observed vs rollout predictions: {os.path.basename(args.data[0])} (first of {len(datasets)} files)"
                 if len(datasets) > 1 else "")
        _plot_rollouts(datasets[0], space, result, os.path.join(out, "observed_vs_predicted.png"), title=title)


def run_identify(args: argparse.Namespace) -> int:
    """Handler of ``tensegrid identify``; returns the process exit code (0 ok, 2 usage or data error)."""
    from physics.errors import TensegridError

    if bool(args.data) == (args.toy is not None):
        print("tensegrid identify: give either DATA.nc files or --toy push (exactly one).", file=sys.stderr)
        return 2
    objective = None
    try:
        objective, truth, datasets = _objective(args)
        os.makedirs(args.out, exist_ok=True)
        result, decoder, grid = _run(args, objective)
    except TensegridError as exc:
        print(f"tensegrid identify: {exc}", file=sys.stderr)
        return 2
    finally:
        close = getattr(objective, "close", None)
        if callable(close):
            close()
    _write(args, result, decoder, grid, truth, datasets)
    print(f"preset {result.config['preset']}: " + " -> ".join(result.config["stages"]))
    print(result.summary(truth=truth))
    print(f"wrote {args.out}/result.nc, summary.txt, marginals.csv, history.csv and figures")
    return 0
