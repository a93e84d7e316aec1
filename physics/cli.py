"""The ``tensegrid`` command line: a thin layer over the Python API.

Sub-commands are registered through the entry-point group ``tensegrid.commands`` (pyproject.toml),
so each package adds its own without physics importing the packages above it. Their descriptions
are often module docstrings in reStructuredText; ``--help`` shows them as plain text (:func:`plain_text`).
"""
from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, entry_points, version
from pathlib import Path
from typing import Any

from physics.errors import TensegridError

__all__ = ["main", "register_simulate", "build_parser", "plain_text"]

_ROLE = re.compile(r":[a-z]+(?::[a-z]+)?:`(~?)([^`]+)`")       # :func:`x`, :meth:`~a.B.c`
_LITERAL = re.compile(r"``([^`]+)``")
_LITERAL_BLOCK = re.compile(r"^[ \t]*::[ \t]*\n(?:[ \t]*\n)?", re.MULTILINE)   # a line that is only "::"
_LITERAL_MARK = re.compile(r"(\S)::$", re.MULTILINE)                  # "as follows::" -> "as follows:"


def plain_text(text: str) -> str:
    """reStructuredText ``text`` as a terminal should show it: roles and inline literals lose their
    markup (:func:`~a.b.c` shows as c, as Sphinx would), a literal block's "::" becomes ":" or goes."""
    text = _ROLE.sub(lambda m: m.group(2).rsplit(".", 1)[-1] if m.group(1) else m.group(2), text)
    text = _LITERAL.sub(r"\1", text)
    return _LITERAL_MARK.sub(r"\1:", _LITERAL_BLOCK.sub("", text))


def _plain_help(parser: argparse.ArgumentParser) -> None:
    """Every description, epilog and help string of ``parser`` and its sub-parsers through :func:`plain_text`."""
    for attr in ("description", "epilog"):
        if getattr(parser, attr):
            setattr(parser, attr, plain_text(getattr(parser, attr)))
    for action in parser._actions:
        if action.help:
            action.help = plain_text(action.help)
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                choice.help = plain_text(choice.help) if choice.help else choice.help
            for sub in {id(p): p for p in action.choices.values()}.values():
                _plain_help(sub)


def _version() -> str:
    """The installed distribution's version (pyproject.toml), or a note when run from an uninstalled tree."""
    try:
        return version("tensegrid")
    except PackageNotFoundError:
        return "(not installed: no package metadata)"


def _parse_assignments(items: Sequence[str]) -> dict[str, float]:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise argparse.ArgumentTypeError(f"--theta expects NAME=VALUE, got {item!r}")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"--theta {name}: {value!r} is not a number") from None
    return out


def _effects(values: dict[str, float]) -> list:
    """The effects whose parameters ``values`` names (physics.effects.EFFECT_TYPES), in catalog order."""
    from physics.effects import EFFECT_TYPES
    from physics.errors import ParameterError

    owners = {p.name: cls for cls in EFFECT_TYPES.values() for p in cls().parameters()}
    unknown = sorted(set(values) - set(owners))
    if unknown:
        raise ParameterError(f"--effect: unknown effect parameter(s) {unknown}; known: {sorted(owners)}.")
    wanted = {owners[name] for name in values}
    return [cls() for cls in EFFECT_TYPES.values() if cls in wanted]


def _run_simulate(args: argparse.Namespace) -> int:
    from physics.controllers import FlopController, HoldController
    from physics.effects import model_space
    from physics.plotting import plot_trajectory
    from physics.simulation import simulate
    from physics.trajectory import save_trajectory

    effects = _effects(_parse_assignments(args.effect))
    space = model_space(effects)
    theta = space.as_array({**_parse_assignments(args.theta), **_parse_assignments(args.effect)}, check_bounds=False)
    controller = (HoldController() if args.flops == 0 else
                  FlopController(args.heading, flops=args.flops, period=args.period))
    duration = args.duration if args.duration is not None else max(1.0, args.flops * args.period)
    ds = simulate(theta, controller=controller, duration=duration, sample_rate=args.rate,
                  noise=args.noise, seed=args.seed, effects=effects)
    out = Path(args.out)
    nc = save_trajectory(ds, out / "trajectory.nc")
    png = plot_trajectory(ds, out / "trajectory.png")
    com = ds["nodes"].mean("node").values
    moved = com[-1, :2] - com[0, :2]
    print(f"simulated {duration:.1f} s ({len(ds.time)} samples at {args.rate:g} Hz); "
          f"centre of mass moved ({moved[0]:+.3f}, {moved[1]:+.3f}) m; peak tension {float(ds.tension.max()):.0f} N")
    print(f"wrote {nc}\nwrote {png}")
    return 0


def register_simulate(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``tensegrid simulate``."""
    p = subparsers.add_parser("simulate", help="simulate the SUPERball flopping; write trajectory.nc and a picture",
                              description="Simulate the T6 at θ (nominal unless --theta) under the flop controller.")
    p.add_argument("--out", default="out/simulate", help="output folder (default: out/simulate)")
    p.add_argument("--theta", nargs="*", default=[], metavar="NAME=VALUE",
                   help="parameter values in SI, e.g. damping=180 pretension=140")
    p.add_argument("--effect", nargs="*", default=[], metavar="NAME=VALUE",
                   help="switch on effects by their parameters, e.g. actuator_delay=0.08 (physics.effects; "
                        "the recording does not name them)")
    p.add_argument("--heading", type=float, default=0.0, help="goal direction in radians from +x (default 0)")
    p.add_argument("--flops", type=int, default=1, help="number of flops (0 = just rest; default 1)")
    p.add_argument("--period", type=float, default=3.0, help="seconds per flop (default 3)")
    p.add_argument("--duration", type=float, default=None, help="seconds to record (default flops x period)")
    p.add_argument("--rate", type=float, default=100.0, help="sampling rate in Hz (default 100)")
    p.add_argument("--noise", type=float, default=0.0, help="std of position noise in m (default 0)")
    p.add_argument("--seed", type=int, default=0, help="seed of the noise (default 0)")
    p.set_defaults(func=_run_simulate)


def _register_commands(sub: argparse._SubParsersAction[Any], command: str | None) -> None:
    """Add the sub-commands: physics' own, then the entry points' (only ``command``'s when it names one;
    none for ``--version``)."""
    found = {ep.name: ep for ep in entry_points(group="tensegrid.commands")}
    if "simulate" not in found:  # running from a source tree without the installed metadata
        register_simulate(sub)
    if "convert" not in found:  # physics' own, registered here rather than as an entry point
        from physics.cli_convert import register_convert

        register_convert(sub)
        if command == "convert":
            return
    if command == "--version":
        return
    names = [command] if command in found else sorted(found)
    for name in names:
        try:
            found[name].load()(sub)
        except ImportError as exc:  # a package not yet installed must not break the others
            print(f"tensegrid: command {name!r} unavailable ({exc})", file=sys.stderr)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser, its help in plain text; with ``command`` given, only that sub-command's package is
    imported (importing belief pulls in torch, which costs seconds)."""
    parser = argparse.ArgumentParser(
        prog="tensegrid", description="Identify tensegrity parameters with DART and Bayesian optimization.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    _register_commands(parser.add_subparsers(dest="command", metavar="COMMAND"), command)
    _plain_help(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv[0] if argv else None)
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except (TensegridError, argparse.ArgumentTypeError) as exc:
        print(f"tensegrid {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
