"""``tensegrid identify``: the command-line layer over :func:`belief.identify`.

::

    tensegrid identify DATA.nc [MORE.nc ...] --decoder {identity,rembo,vae,ae-dyn} --search {bo,random} --budget N --out DIR
    tensegrid identify --toy push --search bo --budget 30 --out DIR

The decoder maps the searched box to θ, the search chooses where to evaluate. ``--decoder
identity`` searches the full space (Sobol candidates; a regular grid when D <= 4), ``rembo`` a
regular grid over a REMBO embedding of dimension ``--dim``, and a trained decoder (``vae``,
``ae-dyn``, ``active``: ``--decoder-file FILE`` written by ``tensegrid train-embedding`` or
``decoder.save``) a regular grid over its latent box. ``--search bo`` is Bayesian optimization, ``random`` random search over the same
cells. Several data files make one objective:
E(θ) sums the one-step errors of all trajectories, each split into ``--windows`` segments.
Writes ``DIR/result.nc`` (see ``IdentificationResult.save``), ``summary.txt`` and
``marginals.csv``, ``history.csv``, ``error_vs_evaluations.png``, ``posterior_marginals.png``
(and ``posterior_2d.png`` for 2-D grids, ``observed_vs_predicted.png`` with rollouts at the
nominal, best and posterior-mean θ of the first trajectory for trajectory data), and journals to
``DIR/journal.sqlite`` so an interrupted run resumes when re-run. When the data files carry the
θ that generated them (simulated data do), the summary shows it next to P's intervals.
``--handoff N`` spends N evaluations in the decoder's grid (journal ``DIR/journal-latent.sqlite``),
then continues BO in the full space with them as its initial design (belief.handoff); P is then
over the full-space candidates.
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Any

__all__ = ["register_identify", "run_identify"]


def register_identify(subparsers: "argparse._SubParsersAction[Any]") -> None:
    """Add the ``identify`` sub-command to a ``tensegrid`` argparse sub-parser collection."""
    p = subparsers.add_parser(
        "identify", help="identify physical parameters from a trajectory (Bayesian optimization, posterior P)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("data", nargs="*", default=[],
                   help="observed trajectories (netCDF, docs/data-format.md); several files make one error E(θ)")
    p.add_argument("--toy", choices=["push"], help="use the 1-D push toy instead of data (no physics engine)")
    p.add_argument("--decoder", choices=["identity", "rembo", "vae", "ae-dyn", "active"], default="identity",
                   help="map from the searched box to θ (default identity: the full space)")
    p.add_argument("--decoder-file", default=None,
                   help="a decoder file: `tensegrid train-embedding` writes vae and ae-dyn, "
                        "ActiveSubspace.save writes active (needed by those three)")
    p.add_argument("--search", choices=["bo", "random"], default="bo", help="how cells are chosen (default bo)")
    p.add_argument("--handoff", type=int, default=None, metavar="N",
                   help="after N evaluations in the decoder's latent grid, continue BO in the full space with "
                        "them as its initial design, up to --budget (belief.handoff)")
    p.add_argument("--budget", type=int, default=50, help="number of evaluations of E (default 50)")
    p.add_argument("--time-budget", type=float, default=None, help="wall-clock budget in seconds")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--dim", type=int, default=5, help="REMBO latent dimension (default 5, capped at D)")
    p.add_argument("--points-per-dim", type=int, default=None,
                   help="grid nodes per latent axis (default 11; 1001 for a 1-D latent)")
    p.add_argument("--candidates", type=int, default=20000, help="Sobol candidates for full-space methods, D > 4")
    p.add_argument("--q", type=int, default=1, help="evaluations per batch (parallel)")
    p.add_argument("--workers", type=int, default=1,
                   help="parallel evaluations of a batch (T6: dask worker processes; 1 = serial)")
    p.add_argument("--posterior", choices=["likelihood", "minimizer"], default="likelihood")
    p.add_argument("--loss", choices=["squared", "norm"], default="squared",
                   help="T6 error: sum of squared residuals (default; what the likelihood posterior assumes) or of norms")
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
    p.set_defaults(func=run_identify)


def _push_objective(seed: int) -> tuple[Any, Any]:
    import numpy as np

    from physics.push import PushError, generate_push_data, push_space

    space = push_space()
    truth = np.array([1.0, 0.4])
    impulses, observed = generate_push_data(truth, n=8, noise_std=0.05, seed=seed)
    return PushError(impulses, observed, space=space, noise_std=0.05), truth


def _plot_rollouts(dataset: Any, space: Any, result: Any, path: str, *, title: str = "") -> None:
    """Observed centre of mass vs open-loop rollouts at the nominal, best and posterior-mean θ, for one trajectory."""
    from physics.error import TrajectoryError
    from physics.errors import PhysicsError
    from physics.plotting import plot_observed_vs_predicted

    thetas = {"nominal": space.nominal, "best": result.best_theta.values,
              "posterior mean": result.marginals["mean"].values}
    preds = {}
    with TrajectoryError([dataset], horizon="rollout", n_workers=0) as roll:
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
    from physics.error import TrajectoryError
    from physics.trajectory import load_trajectory

    datasets = [load_trajectory(path) for path in args.data]
    objective = TrajectoryError(datasets, horizon=1, loss=args.loss, windows=args.windows,
                                n_workers=args.workers if args.workers > 1 else 0)
    return objective, _data_truth(datasets, objective.space), datasets


def _search(args: argparse.Namespace, space: Any) -> tuple[Any, Any]:
    """(decoder, grid): a regular grid over the decoder's box, or Sobol candidates for the identity when D > 4."""
    from belief.grid import Grid, SobolCandidates
    from embeddings import REMBO, Identity, load_decoder
    from embeddings.errors import EmbeddingError

    if args.decoder in ("vae", "ae-dyn", "active"):
        if not args.decoder_file:
            how = ("ActiveSubspace.fit(...).save(FILE)" if args.decoder == "active"
                   else f"`tensegrid train-embedding {args.decoder} --out FILE`")
            raise EmbeddingError(f"--decoder {args.decoder} needs --decoder-file FILE; write one with {how}.")
        decoder = load_decoder(args.decoder_file, space)
        kind = decoder.config()["kind"]
        if kind != args.decoder:
            raise EmbeddingError(f"{args.decoder_file} holds a {kind} decoder, not {args.decoder}; pass --decoder {kind}.")
    elif args.decoder_file:
        raise EmbeddingError(f"--decoder-file is for trained decoders (vae, ae-dyn, active), not --decoder {args.decoder}.")
    elif args.decoder == "rembo":
        decoder = REMBO(space, dim=min(args.dim, space.dim), seed=args.seed)
    else:
        decoder = Identity(space)
    points = args.points_per_dim or (1001 if decoder.dim == 1 else 11)
    if args.decoder == "identity" and space.dim > 4:
        return decoder, SobolCandidates.for_decoder(decoder, n=args.candidates, seed=args.seed)
    return decoder, Grid.for_decoder(decoder, points_per_dim=points)


def _run(args: argparse.Namespace, objective: Any, decoder: Any, grid: Any) -> tuple[Any, Any, Any]:
    """(result, decoder, grid) of identify() with the command line's options, after the hand-over to the
    full space with ``--handoff``; a budget warning goes into the summary, not stderr."""
    import warnings

    from belief.errors import BudgetWarning
    from belief.handoff import continue_in
    from belief.identify import identify
    from belief.posterior import PosteriorConfig
    from embeddings import Identity

    journal = None if (args.journal or "").lower() == "none" else (args.journal or os.path.join(args.out, "journal.sqlite"))
    config = PosteriorConfig(mode=args.posterior, noise_var=args.noise_var, noise_rule=args.noise_rule,
                             discrepancy=args.discrepancy)
    options = dict(time_budget=args.time_budget, seed=args.seed, q=args.q, workers=args.workers,
                   progress=not args.no_progress)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BudgetWarning)      # the summary prints it
        if args.handoff is None:
            return identify(objective, decoder, grid, budget=args.budget, journal=journal, method=args.search,
                            posterior_config=config, **options), decoder, grid
        first = identify(objective, decoder, grid, budget=args.handoff, method=args.search, posterior=None,
                         journal=None if journal is None else os.path.splitext(journal)[0] + "-latent.sqlite",
                         **options)
        result = continue_in(first, objective, Identity(decoder.space), budget=args.budget, n=args.candidates,
                             journal=journal, posterior_config=config, **options)
    return result, Identity(decoder.space), result.belief.grid()


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
    plot_error_trace(result, os.path.join(out, "error_vs_evaluations.png"), label=f"best so far ({args.search}, {args.decoder})")
    plot_marginals(result.posterior, decoder.decode(np.asarray(grid.points)), space,
                   os.path.join(out, "posterior_marginals.png"), marginals=result.marginals, truth=truth)
    if result.posterior.ndim == 2 and result.posterior.dims == ("z0", "z1"):
        plot_posterior_2d(result.posterior, os.path.join(out, "posterior_2d.png"), decoder=decoder,
                          evaluated=h["z"].values, truth=truth)
    if datasets:
        title = (f"observed vs rollout predictions: {os.path.basename(args.data[0])} (first of {len(datasets)} files)"
                 if len(datasets) > 1 else "")
        _plot_rollouts(datasets[0], space, result, os.path.join(out, "observed_vs_predicted.png"), title=title)


def _check_handoff(args: argparse.Namespace) -> None:
    """--handoff needs a reduced decoder and leaves evaluations for the full space."""
    from belief.errors import BudgetError

    if args.handoff is None:
        return
    if args.decoder == "identity":
        raise BudgetError("--handoff hands over from a reduced decoder to the full space; with --decoder identity "
                          "the search is already in the full space. Pass --decoder rembo/vae/ae-dyn/active.")
    if not 1 <= args.handoff < args.budget:
        raise BudgetError(f"--handoff {args.handoff} must be at least 1 and below --budget {args.budget}, which "
                          "counts the evaluations of both stages.")


def run_identify(args: argparse.Namespace) -> int:
    """Handler of ``tensegrid identify``; returns the process exit code (0 ok, 2 usage or data error)."""
    from physics.errors import TensegridError

    if bool(args.data) == (args.toy is not None):
        print("tensegrid identify: give either DATA.nc files or --toy push (exactly one).", file=sys.stderr)
        return 2
    objective = None
    try:
        objective, truth, datasets = _objective(args)
        decoder, grid = _search(args, objective.space)
        os.makedirs(args.out, exist_ok=True)
        _check_handoff(args)
        result, decoder, grid = _run(args, objective, decoder, grid)
    except TensegridError as exc:
        print(f"tensegrid identify: {exc}", file=sys.stderr)
        return 2
    finally:
        close = getattr(objective, "close", None)
        if callable(close):
            close()
    _write(args, result, decoder, grid, truth, datasets)
    print(result.summary(truth=truth))
    print(f"wrote {args.out}/result.nc, summary.txt, marginals.csv, history.csv and figures")
    return 0
