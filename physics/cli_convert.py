"""``tensegrid convert IN.csv OUT.nc``: a CSV of markers and controls to a trajectory file (physics.importers).

The CSV layout (column patterns and node labels, physics.column_patterns), units, up axis and
time unit are physics.importers.from_csv's options; the patterns and labels are checked before the
CSV is read. The whole input is read and validated, then the data checks (physics.checks, as
``tensegrid check``) run on it: when they find an error nothing is written (unless
``--skip-checks``), and the message gives the convert command with the options that fix a units
or up-axis error. Otherwise the file is written through a temporary file, so a failed write leaves
nothing, and never over an existing file unless ``--force``.
"""
from __future__ import annotations

import argparse
import shlex
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, TypeVar, get_args

from physics.errors import ImportFormatError
from physics.outputs import OutputError, check_output_file

if TYPE_CHECKING:
    import xarray as xr

    from physics.findings import DataReport

__all__ = ["ConvertOptions", "register_convert", "run_convert"]

LengthUnit = Literal["m", "cm", "mm"]
TimeUnit = Literal["s", "ms", "us"]
UpAxis = Literal["z", "y", "x", "-z", "-y", "-x"]
_Unit = TypeVar("_Unit", bound=str)
#: Error codes of the checks about node labels: the node numbers they name are positions in --labels.
_LABEL_CODES = ("rod-ends-swapped", "rod-not-rigid", "cable-ends")


@dataclass(frozen=True)
class ConvertOptions:
    """One ``tensegrid convert`` run as given on the command line; each field is the option of its name
    (``skip_checks`` is --skip-checks), ``labels`` the text of --labels. Choices are checked when made;
    patterns and labels by physics.column_patterns."""

    csv: str
    out: str
    units: LengthUnit = "m"
    up: UpAxis = "z"
    time_unit: TimeUnit = "s"
    time_column: str = "time"
    node_columns: str = "node{node}_{axis}"
    control_columns: str = "{cable}"
    rest_length_columns: str = "rest_{cable}"
    labels: str | None = None
    length_reference: Literal["encoder", "true"] | None = None
    delimiter: str = ","
    force: bool = False
    skip_checks: bool = False

    def __post_init__(self) -> None:
        for option, value, allowed in (("--units", self.units, get_args(LengthUnit)),
                                       ("--up", self.up, get_args(UpAxis)),
                                       ("--time-unit", self.time_unit, get_args(TimeUnit)),
                                       ("--length-reference", self.length_reference, (None, "encoder", "true"))):
            if value not in allowed:
                raise ImportFormatError(f"{option} must be one of {', '.join(map(str, allowed))}, got {value!r}.")

    def label_tuple(self) -> tuple[str, ...] | None:
        """--labels as the tuple of node labels (physics.column_patterns.parse_labels), or None."""
        from physics.column_patterns import parse_labels

        return None if self.labels is None else parse_labels(self.labels)

    def command(self) -> str:
        """The shell command of this run: ``tensegrid convert IN OUT`` and every option off its default."""
        argv = ["tensegrid", "convert", self.csv, self.out]
        values = asdict(self)
        for field in fields(self)[2:]:
            value = values[field.name]
            if value == field.default:
                continue
            flag = "--" + field.name.replace("_", "-")
            argv += [flag] if isinstance(value, bool) else [flag, str(value)]
        return shlex.join(argv)


def register_convert(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``tensegrid convert``."""
    from physics.importers import LENGTH_UNITS, TIME_UNITS, UP_AXES

    p = subparsers.add_parser(
        "convert", help="convert a CSV of markers and controls into a trajectory netCDF file",
        description="Read a CSV (one row per sample: time, node coordinates, commanded rest lengths), convert "
                    "lengths to metres, time to seconds and the frame to z up, put the samples on their regular "
                    "clock (jitter snapped, missing timestamps as NaN rows) and run the data checks; write the "
                    "trajectory netCDF only when they find no error (docs/data-format.md, 'Converting a CSV').")
    p.add_argument("csv", help="input CSV file")
    p.add_argument("out", help="output netCDF file (.nc)")
    p.add_argument("--units", choices=list(LENGTH_UNITS), default="m", help="length unit of the CSV (default m)")
    p.add_argument("--up", choices=list(UP_AXES), default="z",
                   help="the CSV axis pointing up, against gravity (default z); the frame is rotated to z up")
    p.add_argument("--time-unit", choices=list(TIME_UNITS), default="s", help="time unit of the CSV (default s)")
    p.add_argument("--time-column", default="time", help="name of the time column (default time)")
    p.add_argument("--labels", default=None, metavar="L0,...,L11",
                   help="comma-separated names of nodes 0..11 in order (rod i joins nodes 2i and 2i+1), for the "
                        "patterns' {label}, {a} and {b}, e.g. A1,A2,B1,B2,... (default: the node numbers)")
    p.add_argument("--node-columns", default="node{node}_{axis}",
                   help="pattern of the node columns: {node} 0..11 or {label}, and {axis} x/y/z or {AXIS} X/Y/Z "
                        "(default node{node}_{axis})")
    p.add_argument("--control-columns", default="{cable}",
                   help="pattern of the commanded rest-length columns: {cable} e.g. c00_04, or {a} and {b}, the "
                        "labels of the cable's end nodes in either order, e.g. motor_{a}_{b} (default {cable})")
    p.add_argument("--rest-length-columns", default="rest_{cable}",
                   help="pattern of the optional measured rest-length columns, as --control-columns "
                        "(default rest_{cable})")
    p.add_argument("--length-reference", choices=["encoder", "true"], default=None,
                   help="what the controls are: encoder readings (the default when left out) or true rest lengths")
    p.add_argument("--delimiter", default=",", help="field separator of the CSV (default ,)")
    p.add_argument("--force", action="store_true", help="overwrite OUT if it exists")
    p.add_argument("--skip-checks", action="store_true", help="write OUT even when the data checks find an error")
    p.set_defaults(func=run_convert)


def _options(args: argparse.Namespace) -> ConvertOptions:
    """The parsed command line as :class:`ConvertOptions`."""
    return ConvertOptions(csv=args.csv, out=args.out, units=args.units, up=args.up, time_unit=args.time_unit,
                          time_column=args.time_column, node_columns=args.node_columns,
                          control_columns=args.control_columns, rest_length_columns=args.rest_length_columns,
                          labels=args.labels, length_reference=args.length_reference, delimiter=args.delimiter,
                          force=args.force, skip_checks=args.skip_checks)


def _output(path: str, force: bool) -> Path:
    """The output path once it is known to be writable as a new file (or ``force``); OutputError else."""
    out = check_output_file(path, option="OUT")
    if out.exists() and not force:
        raise OutputError(f"OUT {path} exists; pass --force to overwrite it or name another file.")
    return out


def _unit_fix(found: float, given: str, table: Mapping[str, float], choices: tuple[_Unit, ...]) -> _Unit | None:
    """The unit of ``choices`` (``table``: name -> SI per unit) that is ``found`` times the ``given`` one, or None."""
    wanted = table[given] * found
    return next((u for u in choices if abs(table[u] / wanted - 1) < 1e-6), None)


def _up_fix(ds: xr.Dataset, report: DataReport, up: str) -> UpAxis | None:
    """The --up under which the checks find the resting robot's floor level below +z, or None: the nodes
    are taken back to the CSV's frame and turned up each way of physics.importers.UP_AXES in turn."""
    import numpy as np

    from physics.checks_robot import check_ground
    from physics.importers import up_rotation
    from physics.parameters import ParameterSpace

    file_nodes = np.asarray(ds["nodes"].values, float) @ up_rotation(up) * report.length_scale
    time = np.asarray(ds["time"].values, float) * report.time_scale
    controls = np.asarray(ds["controls"].values, float)
    radius = ParameterSpace.t6()["radius"].nominal
    candidates: tuple[UpAxis, ...] = get_args(UpAxis)
    for candidate in candidates:
        findings, _ = check_ground(file_nodes @ up_rotation(candidate).T, time, controls, radius)
        codes = {f.code for f in findings}
        if "ground" in codes and not codes & {"up-axis", "not-at-rest"}:
            return candidate
    return None


def _fixed(options: ConvertOptions, ds: xr.Dataset, report: DataReport) -> tuple[ConvertOptions, list[str]]:
    """``options`` with the units, time unit and up axis the checks' errors point to, and a hint for each."""
    from physics.importers import LENGTH_UNITS, TIME_UNITS

    codes = {f.code for f in report.errors}
    lengths: tuple[LengthUnit, ...] = get_args(LengthUnit)
    times: tuple[TimeUnit, ...] = get_args(TimeUnit)
    units = _unit_fix(report.length_scale, options.units, LENGTH_UNITS, lengths) if "length-units" in codes else None
    time_unit = _unit_fix(report.time_scale, options.time_unit, TIME_UNITS, times) if "time-units" in codes else None
    up = _up_fix(ds, report, options.up) if "up-axis" in codes else None
    hints = []
    if units:
        hints.append(f"the CSV's lengths look like {units}: convert again with --units {units}.")
    if time_unit:
        hints.append(f"the CSV's times look like {time_unit}: convert again with --time-unit {time_unit}.")
    if up:
        hints.append(f"the CSV's up axis looks like {up}, not {options.up}: convert again with --up {up}.")
    elif "up-axis" in codes:
        hints.append(f"z is not up after --up {options.up}: convert again with --up set to the CSV axis that points "
                     "up (see the up-axis finding).")
    labels = options.label_tuple()
    if labels is not None and codes & set(_LABEL_CODES):
        legend = ", ".join(f"{n}={label}" for n, label in enumerate(labels))
        hints.append(f"the nodes are the --labels in order ({legend}): reorder --labels as the errors say.")
    fixed = replace(options, units=units or options.units, time_unit=time_unit or options.time_unit,
                    up=up or options.up)
    return fixed, hints


def _as_fixed(ds: xr.Dataset, options: ConvertOptions, fixed: ConvertOptions) -> xr.Dataset:
    """``ds`` as the ``fixed`` options would read the same CSV: from_csv is linear in the units (nodes,
    controls and rest lengths alike), the time unit and the up rotation, so no second read is needed."""
    from physics.importers import LENGTH_UNITS, TIME_UNITS, up_rotation

    ratio = LENGTH_UNITS[fixed.units] / LENGTH_UNITS[options.units]
    turn = up_rotation(fixed.up) @ up_rotation(options.up).T        # world' = R' R^T world
    out = ds.copy()
    nodes = ds["nodes"].transpose("time", "node", "axis")
    out["nodes"] = nodes.copy(data=nodes.values @ turn.T * ratio)
    for var in ("controls", "rest_length"):
        if var in ds:
            out[var] = ds[var].copy(data=ds[var].values * ratio)
    seconds = TIME_UNITS[fixed.time_unit] / TIME_UNITS[options.time_unit]
    return out.assign_coords(time=("time", ds["time"].values * seconds, ds["time"].attrs))


def _refusal(options: ConvertOptions, fixed: ConvertOptions, ds: xr.Dataset, report: DataReport) -> str:
    """Why nothing was written and how to convert again, on one line: the corrected command when the checks
    find no error in the data as it would read."""
    from physics.checks import check_trajectory

    head = (f"the data checks found {len(report.errors)} error(s) in {options.csv}, so nothing was written to "
            f"{options.out}")
    if fixed == options:
        return f"{head}; fix what the errors say, then convert again (or pass --skip-checks to write it anyway)"
    left = check_trajectory(_as_fixed(ds, options, fixed)).errors
    if not left:
        return f"{head}; convert again with: {fixed.command()}"
    codes = ", ".join(dict.fromkeys(f.code for f in left))
    return (f"{head}; convert again with: {fixed.command()} after fixing what the errors {codes} say (or pass "
            "--skip-checks to write it anyway)")


def _write(ds: xr.Dataset, out: Path, option: str) -> None:
    """Save ``ds`` to ``out`` through a temporary file, so a failed write leaves nothing; OutputError then."""
    from physics.trajectory import save_trajectory

    partial = out.with_name(out.name + ".partial")
    try:
        save_trajectory(ds, partial)
        partial.replace(out)
    except OSError as exc:
        partial.unlink(missing_ok=True)
        raise OutputError(f"OUT {option}: cannot write it ({exc.strerror or exc}); name a writable file.") from None


def run_convert(args: argparse.Namespace) -> int:
    """Handler of ``tensegrid convert``: 0 when the file is written, DataCheckError (exit status 2, nothing
    written) when the checks find an error and --skip-checks is not given."""
    from physics.checks import check_trajectory
    from physics.column_patterns import layout_from_options
    from physics.findings import DataCheckError
    from physics.importers import from_csv
    from physics.trajectory import describe_trajectory

    options = _options(args)
    layout_from_options(time_column=options.time_column, node_columns=options.node_columns,
                        control_columns=options.control_columns, rest_length_columns=options.rest_length_columns,
                        labels=options.label_tuple())
    out = _output(options.out, options.force)
    ds = from_csv(options.csv, units=options.units, up=options.up, time_unit=options.time_unit,
                  time_column=options.time_column, node_columns=options.node_columns,
                  control_columns=options.control_columns, rest_length_columns=options.rest_length_columns,
                  labels=options.label_tuple(), length_reference=options.length_reference,
                  delimiter=options.delimiter)
    report = check_trajectory(ds, source=options.csv)
    for line in report.lines(severities=("error", "warning")):
        print(line)
    fixed, hints = _fixed(options, ds, report)
    for hint in hints:
        print(f"hint: {hint}")
    if report.errors and not options.skip_checks:
        raise DataCheckError(_refusal(options, fixed, ds, report))
    _write(ds, out, options.out)
    print(f"wrote {out}: " + "; ".join(describe_trajectory(ds)))
    skipped = " (written anyway: --skip-checks)" if report.errors else ""
    print(f"checks: {len(report.errors)} error(s){skipped}, {len(report.warnings)} warning(s); "
          f"`tensegrid check {out}` prints the whole report.")
    return 0
