"""``tensegrid diagnose``: close the loop on measured trajectories (criticism.diagnose) and write the report.

Registered as a plugin of the ``tensegrid`` command line (entry-point group ``tensegrid.commands``,
pyproject.toml), so physics.cli does not import criticism.
"""
from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from typing import Any

from belief.errors import JournalError
from belief.journal import run_with_journals
from criticism.diagnose import DiagnoseConfig, diagnose
from criticism.errors import CriticismError
from criticism.html_report import write_diagnose_report
from criticism.limits import require_diagnosable
from criticism.mismatch import MismatchConfig
from criticism.report import diagnosis_text, write_report
from criticism.search import CriticismConfig
from criticism.stage_journal import STAGE_JOURNAL
from physics.actuator_choice import add_actuator_option
from physics.cli_check import preflight
from physics.model_file import effects_by_name
from physics.outputs import check_output_dir, output_dir
from physics.parameters import ParameterSpace
from physics.predictor import dt_option
from physics.prior_box import add_prior_box_options, box_changes, prior_box_from_args
from physics.trajectory import describe_trajectory, load_trajectory

__all__ = ["register_diagnose", "run_diagnose"]


def register_diagnose(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``tensegrid diagnose``."""
    p = subparsers.add_parser(
        "diagnose", help="find the effect the model lacks: identify, criticize, add it, re-identify",
        description="Identify the T6 on the fit trajectories, rank the catalog effects by what they explain of the "
                    "held-out residual beyond re-tuning the model's own parameters, add the winner, re-identify, "
                    "and report the held-out error before and after (docs/diagnose.md).")
    p.add_argument("data", nargs="+", help="trajectory netCDF files (docs/data-format.md)")
    p.add_argument("--out", required=True,
                   help="output directory (report.txt, diagnosis.json, model.json, figures, report.html, journals)")
    p.add_argument("--held-out", type=int, nargs="*", default=None,
                   help="indices of the trajectories held out for scoring (default: the last third, at least one)")
    p.add_argument("--effects", nargs="*", default=None,
                   help="effects to try, by name (default: the whole catalog; physics.effects.EFFECT_TYPES)")
    p.add_argument("--budget", type=int, default=40, help="evaluations per identification (default 40)")
    p.add_argument("--passes", type=int, default=2, help="most effects added (default 2)")
    p.add_argument("--horizon", type=int, default=25, help="samples per open-loop prediction window (default 25)")
    p.add_argument("--candidates", type=int, default=2048, help="Sobol candidates per identification")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-progress", action="store_true", help="hide progress bars")
    p.add_argument("--no-mismatch", action="store_true",
                   help="skip the mismatch stage, which by default first absorbs the engine mismatch: re-tunes the T6 "
                        "and adds the component changes (actuator law, cable anchors, end caps) that make it "
                        "reproduce the data (criticism.mismatch); the effects are then searched on that model")
    p.add_argument("--fit-rounds", type=int, default=None, metavar="N",
                   help="most least-squares runs of each of criticism's re-tunings and joint fits, each from the "
                        f"last one's best point until a run gains less than 1 %% (default "
                        f"{CriticismConfig().local.rounds}; 1 is faster and stops short where an effect trades off "
                        "the model's parameters; docs/diagnose.md, step 2)")
    p.add_argument("--suspects", type=int, default=DiagnoseConfig().suspects, metavar="N",
                   help="when no effect is found, give the N best-ranked effects each a second look at the mismatch "
                        "stage's rejected components and take the look that finds its effect with the most evidence "
                        "(default %(default)s; 1: the top effect only; criticism.revisit)")
    p.add_argument("--read-contact", action="store_true",
                   help="first read the end caps' shape and the markers' offset from the flops (criticism.contact): "
                        "flat ends join the model, and an evident offset is added before identifying")
    p.add_argument("--skip-checks", action="store_true",
                   help="do not stop on the data checks' errors, nor on what diagnose cannot use (a robot not at "
                        "rest at the start, jumping markers; tensegrid check; docs/diagnose.md)")
    p.add_argument("--resume", action="store_true",
                   help="continue the journals in OUT (an error when missing or of another problem); without it a "
                        "journal of another problem is set aside (identify_pass0.1.sqlite) and the run starts afresh")
    add_actuator_option(p.add_argument_group("actuator"))
    add_prior_box_options(p)
    p.add_argument("--dt", type=float, default=None, metavar="SECONDS",
                   help="physics step; must divide every file's sampling interval (default: per file, the largest "
                        "step <= 1 ms that does; docs/data-format.md)")
    p.set_defaults(func=run_diagnose)


def _note(text: str) -> None:
    """One line on stderr, ``tensegrid diagnose: note: TEXT``."""
    print(f"tensegrid diagnose: note: {text}", file=sys.stderr)


def _prior_box(args: argparse.Namespace) -> ParameterSpace:
    """The T6's prior box from --nominal, --bounds and --params (physics.prior_box, as identify reads
    them); printed when it differs from the default, so the report's reader sees the box the run used."""
    default = ParameterSpace.t6()
    space = prior_box_from_args(args, default)
    changes = box_changes(space, default)
    if changes:
        print(f"prior box: {len(changes)} of {space.dim} parameters differ from the default:\n  "
              + "\n  ".join(changes))
    return space


def _criticism(fit_rounds: int | None) -> CriticismConfig:
    """CriticismConfig with ``--fit-rounds`` runs per least-squares fit (None: the default's)."""
    if fit_rounds is None:
        return CriticismConfig()
    if fit_rounds < 1:
        raise CriticismError(f"--fit-rounds is the most least-squares runs per fit and must be at least 1, got "
                             f"{fit_rounds}; give 1 for one run, or leave it out for the default.")
    return CriticismConfig(local=replace(CriticismConfig().local, rounds=fit_rounds))


def _before_run(args: argparse.Namespace, config: DiagnoseConfig) -> None:
    """--resume needs the stage's or the first pass's journal; a budget no larger than the first identification's
    initial design (max(5, D + 1) Sobol points, belief.search) means BO never runs: say so."""
    first = os.path.join(args.out, "identify_pass0.sqlite")
    stage = os.path.join(args.out, STAGE_JOURNAL)
    if args.resume and not (os.path.exists(first) or os.path.exists(stage)):
        raise JournalError(f"--resume: no journal at {first} or {stage} to resume; run without --resume to start "
                           "one.")
    n_init = max(5, ParameterSpace.t6().dim + 1)
    if config.budget <= n_init:
        _note(f"--budget {config.budget} is no more than the initial design of {n_init} Sobol points of each "
              f"identification: BO never runs; give --budget {n_init + 1} or more.")


def run_diagnose(args: argparse.Namespace) -> int:
    """Load and check the trajectory files (physics.checks), run :func:`~criticism.diagnose.diagnose`, print
    and write the report (report.txt, diagnosis.json, model.json, figures) to ``--out``; returns the exit status 0.
    Nothing is written before the inputs are valid; a journal of another problem is set aside unless --resume."""
    check_output_dir(args.out)
    space = _prior_box(args)                          # ParameterError (exit 2) before the data are loaded
    data = [load_trajectory(path) for path in args.data]
    if not args.skip_checks:                          # DataCheckError (exit 2) before any identification
        require_diagnosable(preflight(data, args.data, "diagnose", space))
    options = dt_option(getattr(args, "dt", None), data, name="--dt")   # StepSizeError before any identification
    for path, ds in zip(args.data, data, strict=True):
        print(f"{path}: " + "; ".join(describe_trajectory(ds)))
    effects = None if args.effects is None else list(effects_by_name(args.effects))
    config = DiagnoseConfig(passes=args.passes, budget=args.budget, candidates=args.candidates, horizon=args.horizon,
                            seed=args.seed, mismatch=None if args.no_mismatch else MismatchConfig(),
                            read_contact=args.read_contact, criticism=_criticism(args.fit_rounds),
                            suspects=args.suspects, actuator=args.actuator)
    _before_run(args, config)
    with output_dir(args.out):          # removed again if the run fails before writing into it
        diagnosis = run_with_journals(
            lambda: diagnose(data, held_out=args.held_out, effects=effects, config=config, journal_dir=args.out,
                             options=options, progress=not args.no_progress, space=space, say=print),
            resume=args.resume, say=_note)
    print(diagnosis_text(diagnosis))
    for path in [*write_report(diagnosis, data, args.out), write_diagnose_report(args.out, diagnosis, data, args)]:
        print(f"wrote {path}")
    return 0
