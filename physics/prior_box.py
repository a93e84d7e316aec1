"""The prior box from the command line: ``--nominal NAME=VALUE``, ``--bounds NAME=LO:HI`` and
``--params FILE`` turned into a :class:`~physics.parameters.ParameterSpace` (through
:meth:`ParameterSpace.with_overrides`, which validates it), its JSON record and the lines that
print it.

The parameter file is JSON or TOML (by its extension). It maps parameter names to a table with
``nominal`` and/or ``lower`` and ``upper`` (both or neither), in SI units, and optionally
``unit``, which must then be the parameter's own (a guard against millimetres); a bare number is a
nominal::

    {"rod_length": {"nominal": 2.0, "lower": 1.8, "upper": 2.2}, "damping": 150}

    [rod_length]
    nominal = 2.0
    lower = 1.8
    upper = 2.2

``prior_box.json`` written by ``tensegrid identify`` has this format, so it reproduces a run's box.
The command line's values override the file's, parameter by parameter and field by field.

A nominal or a box that lies wholly on one side of the default box, more than
physics.quantities.UNIT_SLIP times away and by the factor of a common wrong unit (1000: millimetres
for metres), is refused as a unit slip naming the SI value meant, by the rule ``--measured`` uses
(physics.quantities.unit_slip); a box far away by no such factor is a robot unlike the default one,
and stays allowed.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import tomllib
from collections.abc import Mapping, Sequence
from typing import Any

from physics.errors import ParameterError
from physics.parameters import ParameterSpace
from physics.quantities import UnitSlip, unit_slip, unit_text

__all__ = ["prior_box", "parse_nominal", "parse_bounds", "read_params_file", "box_record", "box_changes",
           "add_prior_box_options", "prior_box_from_args"]

_FIELDS = ("nominal", "lower", "upper", "unit")


def _number(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ParameterError(f"{what}: {text.strip()!r} is not a number.") from None
    if not math.isfinite(value):
        raise ParameterError(f"{what}: {text.strip()!r} is not a finite number.")
    return value


def _known(name: str, space: ParameterSpace, where: str) -> str:
    if name not in space.names:
        raise ParameterError(f"{where}: unknown parameter {name!r}; the known names are {', '.join(space.names)}.")
    return name


def _assignments(items: Sequence[str], option: str, form: str, space: ParameterSpace) -> dict[str, str]:
    """NAME -> the text after '=' of each item, with known, non-repeated names."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name or not value.strip():
            raise ParameterError(f"{option} expects {form}, got {item!r}.")
        _known(name, space, option)
        if name in out:
            raise ParameterError(f"{option} names {name!r} twice; give each parameter once.")
        out[name] = value
    return out


def parse_nominal(items: Sequence[str], space: ParameterSpace) -> dict[str, float]:
    """``--nominal`` items ``NAME=VALUE`` as name -> SI value."""
    texts = _assignments(items, "--nominal", "NAME=VALUE (SI), e.g. rod_length=2.0", space)
    return {name: _number(text, f"--nominal {name}") for name, text in texts.items()}


def parse_bounds(items: Sequence[str], space: ParameterSpace) -> dict[str, tuple[float, float]]:
    """``--bounds`` items ``NAME=LO:HI`` as name -> (lower, upper) in SI."""
    out = {}
    for name, text in _assignments(items, "--bounds", "NAME=LO:HI (SI), e.g. rod_length=1.8:2.2", space).items():
        lo, sep, hi = text.partition(":")
        if not sep:
            raise ParameterError(f"--bounds expects NAME=LO:HI (SI), e.g. rod_length=1.8:2.2, got {name}={text}.")
        out[name] = (_number(lo, f"--bounds {name} lower"), _number(hi, f"--bounds {name} upper"))
    return out


def _load(path: str) -> Any:
    ext = os.path.splitext(path)[1].lower()
    if ext not in (".json", ".toml"):
        raise ParameterError(f"--params {path}: give a .json or .toml file (docs/parameters.md), not {ext or 'none'}.")
    try:
        with open(path, "rb") as fh:
            return json.load(fh) if ext == ".json" else tomllib.load(fh)
    except FileNotFoundError:
        raise ParameterError(f"--params {path}: no such file.") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ParameterError(f"--params {path}: cannot read it ({str(exc).splitlines()[0]}).") from None


def _entry(path: str, name: str, entry: Any, space: ParameterSpace) -> tuple[float | None, tuple[float, float] | None]:
    """(nominal, bounds) of one entry of a parameter file."""
    where = f"--params {path}: {name}"
    if isinstance(entry, (int, float)) and not isinstance(entry, bool):
        entry = {"nominal": entry}
    if not isinstance(entry, Mapping) or not entry or set(entry) - set(_FIELDS):
        raise ParameterError(f"{where} must be a number or a table of {', '.join(_FIELDS)}, got {entry!r}.")
    for key in ("nominal", "lower", "upper"):
        if key in entry and (isinstance(entry[key], bool) or not isinstance(entry[key], (int, float))):
            raise ParameterError(f"{where}.{key} must be a number (SI), got {entry[key]!r}.")
    unit = space[name].unit
    if "unit" in entry and entry["unit"] != unit:
        raise ParameterError(f"{where} is in {entry['unit']!r}, the parameter in {unit!r}; convert it to {unit}.")
    if ("lower" in entry) != ("upper" in entry):
        raise ParameterError(f"{where} gives one bound; give both lower and upper, or neither.")
    nominal = float(entry["nominal"]) if "nominal" in entry else None
    bounds = (float(entry["lower"]), float(entry["upper"])) if "lower" in entry else None
    return nominal, bounds


def read_params_file(path: str, space: ParameterSpace) -> tuple[dict[str, float], dict[str, tuple[float, float]]]:
    """(nominal values, bounds) by name from a parameter file (module docstring)."""
    data = _load(path)
    if not isinstance(data, Mapping):
        raise ParameterError(f"--params {path}: expected a table of parameters by name, got {type(data).__name__}.")
    nominal: dict[str, float] = {}
    bounds: dict[str, tuple[float, float]] = {}
    for name, entry in data.items():
        value, box = _entry(path, _known(str(name), space, f"--params {path}"), entry, space)
        if value is not None:
            nominal[name] = value
        if box is not None:
            bounds[name] = box
    return nominal, bounds


def _slip(space: ParameterSpace, name: str, values: tuple[float, ...]) -> UnitSlip | None:
    """The unit slip of a nominal ``(value,)`` or a box ``(lo, hi)`` of parameter ``name``: when every
    value lies on one side of ``space``'s box, its nearest value is a unit slip and a common wrong unit
    explains it (physics.quantities.unit_slip); None otherwise."""
    lower, upper = space[name].lower, space[name].upper
    nearest = min(values) if min(values) > upper else max(values) if max(values) < lower else None
    slip = None if nearest is None else unit_slip(space, name, nearest)
    return slip if slip is not None and slip.factor is not None else None


def _refuse_unit_slips(space: ParameterSpace, nominal: Mapping[str, float], bounds: Mapping[str, tuple[float, float]],
                       *, params: str | None) -> None:
    """Raise :class:`ParameterError` (one line, with the SI values meant) for the first parameter whose
    nominal and box together are a unit slip against the default box ``space`` (:func:`_slip`); ``params``
    names the file the values come from, None for the command line's ``--nominal``/``--bounds``."""
    for name in dict.fromkeys([*nominal, *bounds]):
        given = {**({"nominal": nominal[name]} if name in nominal else {}),
                 **(dict(zip(("lower", "upper"), bounds[name], strict=True)) if name in bounds else {})}
        slip = _slip(space, name, tuple(given.values()))
        if slip is None or slip.factor is None:
            continue
        meant = {field: f"{value / slip.factor:.6g}" for field, value in given.items()}
        unit = unit_text(slip.unit)
        if params is not None:
            said = ", ".join(f"{field} = {value:g}" for field, value in given.items())
            write = ", ".join(f"{field} = {value}" for field, value in meant.items())
            raise ParameterError(f"--params {params}: {name} {said}{unit} {slip.clause()}; write {write} in the file.")
        both: list[tuple[str, tuple[str, ...]]] = [(f"--nominal {name}=", ("nominal",)),
                                                   (f"--bounds {name}=", ("lower", "upper"))]
        options = [(option, fields) for option, fields in both if fields[0] in given]
        said = " and ".join(option + ":".join(f"{given[f]:g}" for f in fields) for option, fields in options)
        give = " ".join(option + ":".join(meant[f] for f in fields) for option, fields in options)
        raise ParameterError(f"{said}{unit} {slip.clause()}; give {give}.")


def prior_box(space: ParameterSpace, *, nominal: Sequence[str] = (), bounds: Sequence[str] = (),
              params: str | None = None) -> ParameterSpace:
    """``space`` with the box given by a parameter file and the ``--nominal``/``--bounds`` items
    (these win); ``space`` itself when none is given. Raises :class:`ParameterError`, one line, for a
    malformed item and for a unit slip against ``space``'s box (module docstring)."""
    file_nominal, file_bounds = read_params_file(params, space) if params else ({}, {})
    cli_nominal, cli_bounds = parse_nominal(nominal, space), parse_bounds(bounds, space)
    _refuse_unit_slips(space, file_nominal, file_bounds, params=params)
    _refuse_unit_slips(space, cli_nominal, cli_bounds, params=None)
    if not (file_nominal or file_bounds or cli_nominal or cli_bounds):
        return space
    return space.with_overrides(nominal={**file_nominal, **cli_nominal}, bounds={**file_bounds, **cli_bounds})


def box_record(space: ParameterSpace) -> dict[str, dict[str, Any]]:
    """name -> {unit, nominal, lower, upper}: JSON-able, and a valid ``--params`` file."""
    return {p.name: {"unit": p.unit, "nominal": p.nominal, "lower": p.lower, "upper": p.upper} for p in space}


def box_changes(space: ParameterSpace, default: ParameterSpace) -> list[str]:
    """One line per parameter whose nominal or box differs from ``default`` (same names), for printing."""
    lines = []
    for p, d in zip(space, default, strict=True):
        if (p.nominal, p.lower, p.upper) != (d.nominal, d.lower, d.upper):
            lines.append(f"{p.name} = {p.nominal:.6g} {p.unit} in [{p.lower:.6g}, {p.upper:.6g}] "
                         f"(default {d.nominal:.6g} in [{d.lower:.6g}, {d.upper:.6g}])")
    return lines


def add_prior_box_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--nominal``, ``--bounds`` and ``--params`` (read them with :func:`prior_box_from_args`)."""
    parser.add_argument("--nominal", action="append", default=[], metavar="NAME=VALUE",
                        help="recentre a parameter's prior box on VALUE (SI), keeping its relative width (±10 %%); "
                             "repeatable")
    parser.add_argument("--bounds", action="append", default=[], metavar="NAME=LO:HI",
                        help="a parameter's prior box in SI, e.g. rod_length=1.8:2.2; repeatable")
    parser.add_argument("--params", default=None, metavar="FILE",
                        help="prior box from a JSON or TOML file {name: {nominal, lower, upper}} (docs/parameters.md; "
                             "a run's prior_box.json); --nominal and --bounds override it")


def prior_box_from_args(args: argparse.Namespace, space: ParameterSpace) -> ParameterSpace:
    """:func:`prior_box` of the options :func:`add_prior_box_options` added."""
    return prior_box(space, nominal=args.nominal, bounds=args.bounds, params=args.params)
