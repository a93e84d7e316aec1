"""The ``tensegrid`` command line: a thin layer over the Python API.

Sub-commands are registered through the entry-point group ``tensegrid.commands`` (pyproject.toml),
so each package adds its own without physics importing the packages above it. Their descriptions
are often module docstrings in reStructuredText; ``--help`` shows them as plain text (:func:`plain_text`).
Every sub-command runs inside :func:`physics.cli_warnings.plain_warnings`: a Python warning shows as
one plain note, never as a source line.
"""
from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, entry_points, version
from typing import Any

from physics.cli_warnings import plain_warnings
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


def register_simulate(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``tensegrid simulate`` (physics.cli_simulate)."""
    from physics.cli_simulate import register_simulate as register

    register(subparsers)


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
        with plain_warnings(args.command):      # every sub-command: warnings as one plain note each
            return int(args.func(args) or 0)
    except (TensegridError, argparse.ArgumentTypeError) as exc:
        print(f"tensegrid {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
