"""``tensegrid check DATA.nc [MORE.nc ...]``: the pre-flight report of trajectory files (physics.checks).

Prints one line per finding (``FILE: severity code: message Fix: fix``, errors first) and a
summary; exits 0 when no file has an error, 2 when any has. :func:`preflight` runs the same checks
for ``identify`` and ``diagnose`` before any evaluation.
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

import xarray as xr

from physics.checks import check_file, require_clean, require_rods_in_box
from physics.findings import DataReport, Severity
from physics.parameters import ParameterSpace

__all__ = ["register_check", "run_check", "preflight"]


def register_check(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``tensegrid check``."""
    p = subparsers.add_parser(
        "check", help="pre-flight report of trajectory files: units, up axis, floor, labels, gaps, controls",
        description="Check trajectory files against the data format and the robot (docs/data-format.md, "
                    "'Checking a file'): units from rod lengths and sampling rate, the up axis and floor from the "
                    "resting robot, swapped rod ends, dropouts and jumps, the controls. One line per finding with "
                    "its fix; exit status 2 when any file has an error.")
    p.add_argument("data", nargs="+", help="trajectory netCDF files")
    p.add_argument("--quiet", action="store_true", help="print errors and warnings only (no info lines)")
    p.set_defaults(func=run_check)


def run_check(args: argparse.Namespace) -> int:
    """Handler of ``tensegrid check``: 0 when no file has an error, 2 otherwise."""
    severities: tuple[Severity, ...] = ("error", "warning") if args.quiet else ("error", "warning", "info")
    reports: list[DataReport] = []
    for path in args.data:
        report = check_file(path)
        reports.append(report)
        for line in report.lines(severities=severities):
            print(line)
    errors = sum(len(r.errors) for r in reports)
    warnings = sum(len(r.warnings) for r in reports)
    bad = sum(1 for r in reports if r.errors)
    print(f"{len(reports)} file(s): {errors} error(s) in {bad} file(s), {warnings} warning(s).")
    return 2 if bad else 0


def preflight(datasets: Sequence[xr.Dataset], sources: Sequence[str], command: str,
              space: ParameterSpace | None = None) -> list[DataReport]:
    """The checks ``identify`` and ``diagnose`` run first: print each warning to stderr as
    ``tensegrid COMMAND: note: ...``; raise DataCheckError (one line per error) if any file has an error.
    With ``space``, the prior box the command identifies in: the checks use its box, and a rod_length
    box that excludes the rods the markers measure is a ParameterError (physics.checks.require_rods_in_box)."""
    reports = require_clean(datasets, sources, space)
    if space is not None:
        require_rods_in_box(reports, space)
    for report in reports:
        for line in report.lines(severities=("warning",)):
            print(f"tensegrid {command}: note: {line}", file=sys.stderr)
    return reports
