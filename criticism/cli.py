"""``tensegrid diagnose``: close the loop on measured trajectories (criticism.diagnose) and write the report.

Registered as a plugin of the ``tensegrid`` command line (entry-point group ``tensegrid.commands``,
pyproject.toml), so physics.cli does not import criticism.
"""
from __future__ import annotations

import argparse
from typing import Any

from criticism.diagnose import DiagnoseConfig, diagnose
from criticism.report import diagnosis_text, write_report
from physics.cli_check import preflight
from physics.effects import EFFECT_TYPES
from physics.errors import ParameterError
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
    p.add_argument("--out", required=True, help="output directory (report.txt, diagnosis.json, figures, journals)")
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
    p.add_argument("--skip-checks", action="store_true",
                   help="do not stop on the data checks' errors (tensegrid check; docs/data-format.md)")
    p.set_defaults(func=run_diagnose)


def run_diagnose(args: argparse.Namespace) -> int:
    """Load and check the trajectory files (physics.checks), run :func:`~criticism.diagnose.diagnose`, print
    and write the report (report.txt, diagnosis.json, figures) to ``--out``; returns the exit status 0."""
    data = [load_trajectory(path) for path in args.data]
    if not getattr(args, "skip_checks", False):
        preflight(data, args.data, "diagnose")       # raises DataCheckError (exit 2) before any identification
    for path, ds in zip(args.data, data, strict=True):
        print(f"{path}: " + "; ".join(describe_trajectory(ds)))
    effects = None
    if args.effects is not None:
        unknown = sorted(set(args.effects) - set(EFFECT_TYPES))
        if unknown:
            raise ParameterError(f"unknown effect(s) {unknown}; known effects are {sorted(EFFECT_TYPES)}.")
        effects = [EFFECT_TYPES[name]() for name in args.effects]
    config = DiagnoseConfig(passes=args.passes, budget=args.budget, candidates=args.candidates,
                            horizon=args.horizon, seed=args.seed)
    diagnosis = diagnose(data, held_out=args.held_out, effects=effects, config=config, journal_dir=args.out,
                         progress=not args.no_progress)
    print(diagnosis_text(diagnosis))
    for path in write_report(diagnosis, data, args.out):
        print(f"wrote {path}")
    return 0
