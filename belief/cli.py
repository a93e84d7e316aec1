"""``tensegrid identify``: the command-line layer over :func:`belief.presets.run_preset`.

::

    tensegrid identify DATA.nc [MORE.nc ...] [--preset handoff-gn] --budget N --out DIR
    tensegrid identify DATA.nc --preset latent --decoder ae-dyn --decoder-file ae.json --budget N --out DIR
    tensegrid identify --toy push --preset bo --budget 30 --out DIR

``--preset`` names the recipe (belief.presets): ``handoff-gn`` (default, the best measured) spends
``--latent`` evaluations of BO in a learned 5-D latent grid, continues BO in the full space over
``--candidates`` Sobol points with them as its initial design, and finishes with one
Gauss-Newton step (D + 4 evaluations); ``handoff`` stops before the step, though its verdicts
may take the same step; ``--budget`` counts every evaluation of E but the ``-local`` presets' local
stage; ``bo-gn``/``bo`` search the full space only, ``random`` is random search there, and
``latent`` searches only the latent grid. The latent decoder is the one shipped for the T6's
default box, or ``--decoder rembo`` (a random embedding of dimension ``--dim``) or a trained
decoder (``vae``, ``ae-dyn``, ``active``: ``--decoder-file FILE`` written by ``tensegrid
train-embedding`` or ``decoder.save``). Several data files make one objective: E(θ) sums the
one-step errors of all trajectories, each split into ``--windows`` segments.

Writes ``DIR/result.nc`` (``IdentificationResult.save``), ``summary.txt``, ``marginals.csv``,
``history.csv``, the figures (``error_vs_evaluations.png``, ``posterior_marginals.png``, ``pairs.png``,
``posterior_2d.png`` for 2-D grids, ``observed_vs_predicted.png`` for trajectory data), ``report.html``
(one self-contained page to hand on), for trajectory data ``next_recording.json`` (the flop to record
next, belief.next_recording; ``--no-next`` skips it; ``tensegrid probe --next`` runs it), and
journals (``journal.sqlite``, ``journal-latent.sqlite``) so an interrupted run resumes when re-run; a
journal of another problem is set aside (``journal.1.sqlite``) unless ``--resume``. The prior box:
``--nominal NAME=VALUE``, ``--bounds NAME=LO:HI``, ``--params FILE`` (physics.prior_box), saved as
``prior_box.json``. What you know: ``--measured NAME=VALUE+-SD`` (a parameter or rod_mass,
total_mass, rod_inertia) and ``--fix NAME=VALUE`` (held), checked against the box before anything
runs (physics.measurements); the fixed ones leave the search, the measured ones do not change P in
this version. ``--effects A B`` or ``--model DIR/model.json`` (from ``tensegrid diagnose``) identify
the T6 with those effects (physics.model_file). When the data files carry the θ that generated them
(simulated data do), the summary shows it. The data files are checked first as by ``tensegrid
check`` (docs/data-format.md): an error stops the run before any
evaluation, unless ``--skip-checks``.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
from typing import TYPE_CHECKING, Any

from belief.cli_next import add_next_options
from belief.noise import DEFAULT_DISCREPANCY, NOISE_RULES
from belief.presets import DEFAULT_PRESET, PRESETS
from physics.actuator_choice import add_actuator_option
from physics.measurements import add_measurement_options
from physics.prior_box import add_prior_box_options, box_record
from physics.state_estimation import STATE_METHODS

if TYPE_CHECKING:                   # the engine and torch load only when a command needs them
    from belief.grid import CandidateSet
    from belief.presets import Preset
    from belief.result import IdentificationResult
    from embeddings.base import Decoder
    from physics.effects import Effect
    from physics.measurements import MeasurementPrior
    from physics.objective import Objective
    from physics.parameters import ParameterSpace

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
    _add_search_options(p.add_argument_group("search"))
    _add_error_options(p.add_argument_group("error and posterior"))
    _add_model_options(p)
    add_prior_box_options(p)
    add_measurement_options(p)
    run = p.add_argument_group("run")
    run.add_argument("--out", required=True, help="output directory")
    run.add_argument("--journal", default=None, help="SQLite journal (default OUT/journal.sqlite); 'none' disables")
    run.add_argument("--resume", action="store_true",
                     help="continue the journal (an error when it is missing or of another problem); without it a "
                          "journal of another problem is set aside as journal.1.sqlite and the run starts afresh")
    run.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    run.add_argument("--skip-checks", action="store_true",
                     help="do not stop on the data checks' errors (tensegrid check; docs/data-format.md)")
    add_next_options(run)
    p.set_defaults(func=run_identify)


def _add_search_options(g: argparse._ArgumentGroup) -> None:
    """Options of the Bayesian-optimization search: recipe, decoder, grid and budget."""
    g.add_argument("--preset", choices=list(PRESETS), default=DEFAULT_PRESET,
                   help=f"identification recipe (belief.presets; default {DEFAULT_PRESET}, the best measured)")
    g.add_argument("--decoder", choices=["rembo", "vae", "ae-dyn", "active"], default=None,
                   help="latent decoder of the presets with a latent stage (default: the one shipped for the T6's "
                        "default box)")
    g.add_argument("--decoder-file", default=None,
                   help="a decoder file: `tensegrid train-embedding` writes vae and ae-dyn, "
                        "ActiveSubspace.save writes active (needed by those three)")
    g.add_argument("--latent", type=int, default=None, metavar="N",
                   help="evaluations of the latent stage of the handoff presets (default 15)")
    g.add_argument("--budget", type=int, default=50,
                   help="evaluations of E the run makes at most, the Gauss-Newton step after the search included "
                        "(default 50; the -local presets' local stage adds its own)")
    g.add_argument("--time-budget", type=float, default=None, help="wall-clock budget in seconds")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--dim", type=int, default=5, help="--decoder rembo: latent dimension (default 5, capped at D)")
    g.add_argument("--points-per-dim", type=int, default=None,
                   help="grid nodes per latent axis, and per axis of a full space of D <= 4 (default 11)")
    g.add_argument("--candidates", type=int, default=4096, help="Sobol candidates of the full-space search, D > 4")
    g.add_argument("--q", type=int, default=1, help="evaluations per batch (parallel)")
    g.add_argument("--workers", type=int, default=1,
                   help="parallel evaluations of a batch (T6: dask worker processes; 1 = serial)")


def _add_error_options(g: argparse._ArgumentGroup) -> None:
    """Options of the T6's error E(θ) and of the posterior P built from it."""
    g.add_argument("--posterior", choices=["likelihood", "minimizer"], default="likelihood")
    g.add_argument("--loss", choices=["squared", "norm"], default="squared",
                   help="T6 error: sum of squared residuals (default; what the likelihood posterior assumes) "
                        "or of norms")
    g.add_argument("--windows", type=int, default=3,
                   help="T6 error: contiguous segments per trajectory whose errors sum to E (default 3)")
    g.add_argument("--noise-var", type=float, default=None, help="sigma^2 of the likelihood posterior (units of E)")
    g.add_argument("--noise-rule", choices=list(NOISE_RULES), default="ess",
                   help="sigma^2 when not given: 'ess' (effective residual count, the model-error floor always; "
                        "default), 'calibrated' (block sandwich at a local fit, the floor only where the residuals "
                        "exceed what the measured noise leaves) or 'iid' (E_min / (K - d)); docs/identification.md")
    g.add_argument("--discrepancy", type=float, default=DEFAULT_DISCREPANCY,
                   help=f"relative excess error that costs one nat at least where the model falls short of the "
                        f"data, a prior on model error (default {DEFAULT_DISCREPANCY})")
    g.add_argument("--states", choices=list(STATE_METHODS), default="local-polynomial",
                   help="T6 error: how the states predictions start from are estimated from positions: "
                        "'local-polynomial' (leaves out the compared sample; default) or 'backward' (the paper's "
                        "backward difference, biased under noise); physics.state_estimation")
    g.add_argument("--dt", type=float, default=None, metavar="SECONDS",
                   help="physics step; must divide every file's sampling interval (default: per file, the largest "
                        "step <= 1 ms that does; docs/data-format.md)")


def _add_model_options(p: argparse.ArgumentParser) -> None:
    """The model's effects: named on the command line or read from diagnose's model file (one or the other)."""
    model = p.add_argument_group("model").add_mutually_exclusive_group()
    model.add_argument("--effects", nargs="+", default=None, metavar="NAME",
                       help="identify the T6 with these effects, their parameters too (physics.effects.EFFECT_TYPES, "
                            "e.g. tension_limited_actuator cable_anchors)")
    model.add_argument("--model", default=None, metavar="FILE",
                       help="identify with the effects of a model file: DIR/model.json of tensegrid diagnose")
    add_actuator_option(p.add_argument_group("actuator"))


def _latent_decoder(args: argparse.Namespace, space: ParameterSpace) -> Decoder | None:
    """The latent decoder named on the command line, else the one shipped for this box when the preset
    has a latent stage, else None (such a preset then runs without it, with a PresetWarning)."""
    from embeddings import REMBO, load_decoder
    from embeddings.errors import EmbeddingError
    from embeddings.pretrained import pretrained_decoder

    if args.decoder is None:
        if args.decoder_file:
            raise EmbeddingError("--decoder-file needs --decoder vae, ae-dyn or active (the kind the file holds).")
        return pretrained_decoder(space) if PRESETS[args.preset].uses_latent else None
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


def _preset(args: argparse.Namespace) -> Preset:
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


def _run(args: argparse.Namespace, objective: Objective, decoder: Decoder | None, effects: tuple[Effect, ...],
         known: MeasurementPrior) -> tuple[IdentificationResult, Decoder, CandidateSet]:
    """(result, decoder, grid of P) of the preset with the command line's options; a budget warning goes
    into the summary, not stderr; a journal of another problem is set aside unless --resume. The config
    records the whole prior box and what the user measured and fixed (``known``)."""
    import warnings

    from belief.errors import BeliefError, BudgetWarning
    from belief.journal import run_with_journals
    from belief.posterior import PosteriorConfig
    from belief.presets import PresetWarning, run_preset

    journal = _journal_path(args)
    config = PosteriorConfig(mode=args.posterior, noise_var=args.noise_var, noise_rule=args.noise_rule,
                             discrepancy=args.discrepancy)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("ignore", BudgetWarning)      # the summary prints it
        warnings.simplefilter("always", PresetWarning)
        result = run_with_journals(
            lambda: run_preset(objective, _preset(args), budget=args.budget, seed=args.seed, decoder=decoder,
                               journal=journal, posterior=config, time_budget=args.time_budget, q=args.q,
                               measurements=known if known.measurements else None,
                               progress=not args.no_progress),
            resume=args.resume, say=_note)
    for note in dict.fromkeys(str(n.message) for n in caught):     # one line each, once
        _note(note)
    result.config["prior_box"] = box_record(known.space)
    result.config["measurements"] = known.config()["measurements"]
    result.config["fixed"] = dict(known.fixed)
    result.config["effects"] = [e.config() for e in effects]      # the model identified (physics.model_file)
    if result.belief is None:       # run_preset builds one whenever a posterior mode is set, as here
        raise BeliefError("the identification returned no belief; the command line needs its posterior.")
    return result, result.belief.decoder(), result.belief.grid()


def _note(text: str) -> None:
    """One line on stderr, ``tensegrid identify: note: TEXT`` (warnings, resumed and set-aside journals)."""
    print(f"tensegrid identify: note: {text}", file=sys.stderr)


def _journal_path(args: argparse.Namespace) -> str | None:
    """--journal, by default OUT/journal.sqlite; None for 'none'."""
    journal: str = args.journal or os.path.join(args.out, "journal.sqlite")
    return None if journal.lower() == "none" else journal


def _budget_note(args: argparse.Namespace, decoder: Decoder | None, dim: int) -> str | None:
    """The warning for a budget that leaves BO nothing after its initial design of max(5, d + 1) Sobol
    points (belief.search), so that BO never runs; None when BO runs or the preset refuses the budget."""
    from dataclasses import replace

    from belief.presets import minimum_budget, reserved_evaluations
    from belief.search import default_n_init

    preset = _preset(args)
    if preset.uses_latent and decoder is None and preset.search is not None:
        preset = replace(preset, latent=0)          # the preset runs without its latent stage (PresetWarning)
    bo_only, latent_only = preset.search == "bo" and preset.latent == 0, preset.search is None and decoder is not None
    if not (bo_only or latent_only) or args.budget < minimum_budget(preset, dim):
        return None
    step = reserved_evaluations(preset, dim)
    n_init = default_n_init(decoder.dim if latent_only and decoder is not None else dim)
    search = args.budget - step
    if search > n_init:
        return None
    where = "the latent grid" if preset.search is None else "the full space"
    spent = f" after the {step} of the Gauss-Newton step after it" if step else ""
    return (f"--budget {args.budget} leaves {search} evaluations{spent} for BO over {where}, no more than its "
            f"initial design of {n_init} Sobol points: BO never runs (whatever the progress bar says); give "
            f"--budget {args.budget - search + n_init + 1} or more.")


def _before_run(args: argparse.Namespace, objective: Objective, decoder: Decoder | None, effects: tuple[Effect, ...],
                known: MeasurementPrior) -> None:
    """The checks and notes due before anything is written: the budget, a journal to --resume, the
    prior box (every parameter, printed when it differs from the default), a budget that leaves BO no step
    and what the measurements do."""
    from belief.cli_problem import default_space
    from belief.errors import BudgetError, JournalError
    from physics.outputs import check_output_file
    from physics.prior_box import box_changes

    if args.budget < 1:
        raise BudgetError(f"budget must be >= 1 evaluation, got --budget {args.budget}; a zero budget identifies "
                          "nothing.")
    journal = _journal_path(args)
    if journal is not None and args.journal:
        check_output_file(journal, option="--journal")
    if args.resume:
        latent = None if journal is None else os.path.splitext(journal)[0] + "-latent.sqlite"
        if journal is None or not (os.path.exists(journal) or os.path.exists(str(latent))):
            raise JournalError(f"--resume: no journal at {journal} to resume; run without --resume to start one.")
    changes = box_changes(known.space, default_space(args, effects))
    if changes:
        print(f"prior box: {len(changes)} of {known.space.dim} parameters differ from the default:\n  "
              + "\n  ".join(changes))
    note = _budget_note(args, decoder, objective.space.dim)
    if note:
        _note(note)
    if known.measurements:
        _note("--measured values enter the posterior of the local stage (presets '*-local', belief.local_belief), "
              "not the global search; recorded in result.nc and summary.txt")


def run_identify(args: argparse.Namespace) -> int:
    """Handler of ``tensegrid identify``; returns the process exit code (0 ok, 2 usage or data error)."""
    from belief.cli_next import design_next, write_next
    from belief.cli_outputs import actuator_lines, write_outputs
    from belief.cli_problem import build_problem, model_effects
    from physics.errors import TensegridError
    from physics.outputs import check_output_dir, output_dir

    if bool(args.data) == (args.toy is not None):
        hint = " --effects takes every name after it: put it after the data files." if args.effects else ""
        print(f"tensegrid identify: give either DATA.nc files or --toy push (exactly one).{hint}", file=sys.stderr)
        return 2
    with contextlib.ExitStack() as cleanup:     # closes the objective's workers before the figures
        try:
            check_output_dir(args.out)
            effects = model_effects(args)       # the model file is read once; refused with the toy
            problem = build_problem(args, effects, cleanup)
            objective, truth, datasets = problem.objective, problem.truth, problem.datasets
            known, effects = problem.known, problem.effects
            latent = _latent_decoder(args, objective.space)
            _before_run(args, objective, latent, effects, known)
            with output_dir(args.out):          # removed again if the run fails before writing into it
                result, decoder, grid = _run(args, objective, latent, effects, known)
            if problem.actuator is not None:
                result.config["actuator"] = problem.actuator.as_dict()
        except TensegridError as exc:
            print(f"tensegrid identify: {exc}", file=sys.stderr)
            return 2
        suggestion = None if args.no_next or not datasets else design_next(result, objective, known, say=_note)
    if suggestion is not None:
        result.config["next_recording"] = suggestion.as_dict()        # result.nc and report.html carry it
    write_outputs(args, result, decoder, grid, truth, datasets, effects, known=known)
    print(f"preset {result.config['preset']}: " + " -> ".join(result.config["stages"]))
    print("\n".join(filter(None, [result.summary(truth=truth), known.summary(), *actuator_lines(result)])))
    if suggestion is not None:
        print("\n".join(write_next(args.out, suggestion)))
    print(f"wrote {args.out}/report.html (one page to hand on), result.nc, summary.txt, marginals.csv, history.csv, "
          "prior_box.json and figures")
    return 0
