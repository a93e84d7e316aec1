"""``tensegrid convert IN.csv OUT.nc``: a CSV of markers and controls to a trajectory file (physics.importers).

The CSV layout, units, up axis and time unit are physics.importers.from_csv's options; the
output is written only after the whole input has been read and validated (through a temporary
file, so a failed write leaves nothing), never over an existing file unless ``--force``. Then the
data checks (physics.checks, as ``tensegrid check``) run on the result and their errors and
warnings are printed, with the convert option that fixes a units or up-axis error; the exit
status is 2 when they find an error.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from physics.outputs import OutputError, check_output_file

__all__ = ["register_convert", "run_convert"]


def register_convert(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``tensegrid convert``."""
    from physics.importers import LENGTH_UNITS, TIME_UNITS, UP_AXES

    p = subparsers.add_parser(
        "convert", help="convert a CSV of markers and controls into a trajectory netCDF file",
        description="Read a CSV (one row per sample: time, node coordinates, commanded rest lengths), convert "
                    "lengths to metres, time to seconds and the frame to z up, put the samples on their regular "
                    "clock (jitter snapped, missing timestamps as NaN rows) and write the trajectory netCDF "
                    "(docs/data-format.md, 'Converting a CSV'). Then run the data checks on it.")
    p.add_argument("csv", help="input CSV file")
    p.add_argument("out", help="output netCDF file (.nc)")
    p.add_argument("--units", choices=list(LENGTH_UNITS), default="m", help="length unit of the CSV (default m)")
    p.add_argument("--up", choices=list(UP_AXES), default="z",
                   help="the CSV axis pointing up, against gravity (default z); the frame is rotated to z up")
    p.add_argument("--time-unit", choices=list(TIME_UNITS), default="s", help="time unit of the CSV (default s)")
    p.add_argument("--time-column", default="time", help="name of the time column (default time)")
    p.add_argument("--node-columns", default="node{node}_{axis}",
                   help="pattern of the node columns, fields {node} 0..11 and {axis} x/y/z (default node{node}_{axis})")
    p.add_argument("--control-columns", default="{cable}",
                   help="pattern of the commanded rest-length columns, field {cable} e.g. c00_04 (default {cable})")
    p.add_argument("--rest-length-columns", default="rest_{cable}",
                   help="pattern of the optional measured rest-length columns (default rest_{cable})")
    p.add_argument("--length-reference", choices=["encoder", "true"], default=None,
                   help="what the controls are: encoder readings (the default when left out) or true rest lengths")
    p.add_argument("--delimiter", default=",", help="field separator of the CSV (default ,)")
    p.add_argument("--force", action="store_true", help="overwrite OUT if it exists")
    p.set_defaults(func=run_convert)


def _output(path: str, force: bool) -> Path:
    """The output path once it is known to be writable as a new file (or ``force``); OutputError else."""
    out = check_output_file(path, option="OUT")
    if out.exists() and not force:
        raise OutputError(f"OUT {path} exists; pass --force to overwrite it or name another file.")
    return out


def _hints(codes: tuple[str, ...], length_scale: float, time_scale: float, args: argparse.Namespace) -> list[str]:
    """The convert options that fix a units or up-axis finding of the checks (the unit found is the one
    given times the scale the checks detected)."""
    from physics.importers import LENGTH_UNITS, TIME_UNITS

    out = []
    if "length-units" in codes:
        wanted = LENGTH_UNITS[args.units] * length_scale
        name = next((u for u, f in LENGTH_UNITS.items() if abs(f / wanted - 1) < 1e-6), None)
        if name:
            out.append(f"the CSV's lengths look like {name}: convert again with --units {name} --force.")
    if "time-units" in codes:
        wanted = TIME_UNITS[args.time_unit] * time_scale
        name = next((u for u, f in TIME_UNITS.items() if abs(f / wanted - 1) < 1e-6), None)
        if name:
            out.append(f"the CSV's times look like {name}: convert again with --time-unit {name} --force.")
    if "up-axis" in codes:
        out.append(f"z is not up after --up {args.up}: convert again with --up set to the CSV axis that points up "
                   "(see the up-axis finding) --force.")
    return out


def run_convert(args: argparse.Namespace) -> int:
    """Handler of ``tensegrid convert``: 0 when the written file has no check error, 2 otherwise."""
    from physics.checks import check_trajectory
    from physics.importers import from_csv
    from physics.trajectory import describe_trajectory, save_trajectory

    out = _output(args.out, args.force)
    ds = from_csv(args.csv, units=args.units, up=args.up, time_unit=args.time_unit, time_column=args.time_column,
                  node_columns=args.node_columns, control_columns=args.control_columns,
                  rest_length_columns=args.rest_length_columns, length_reference=args.length_reference,
                  delimiter=args.delimiter)
    partial = out.with_name(out.name + ".partial")
    try:
        save_trajectory(ds, partial)
        partial.replace(out)
    except OSError as exc:
        partial.unlink(missing_ok=True)
        raise OutputError(f"OUT {args.out}: cannot write it ({exc.strerror or exc}); name a writable file.") from None
    print(f"wrote {out}: " + "; ".join(describe_trajectory(ds)))
    report = check_trajectory(ds, source=str(out))
    for line in report.lines(severities=("error", "warning")):
        print(line)
    for hint in _hints(report.codes, report.length_scale, report.time_scale, args):
        print(f"hint: {hint}")
    print(f"checks: {len(report.errors)} error(s), {len(report.warnings)} warning(s); `tensegrid check {out}` "
          "prints the whole report.")
    return 2 if report.errors else 0
