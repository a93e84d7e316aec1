"""The README against the program: its command table lists exactly the options argparse declares,
its examples run as written, ``--help`` is plain text and the API's defaults are the command line's.

The parser is the one ``tensegrid`` builds (physics.cli.build_parser, with every sub-command of the
``tensegrid.commands`` entry points); the README's "Command line" section has one table row per
sub-command, the options in its last column.
"""
from __future__ import annotations

import argparse
import inspect
import re
import shlex
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import pytest

from physics.cli import build_parser

README = Path(__file__).resolve().parents[1] / "README.md"
RUN = {"simulate", "check"}        # sub-commands the test runs from the README (seconds); the others are parsed
RST = re.compile(r"``|:[a-z]+(?::[a-z]+)?:`|^\s*::\s*$", re.MULTILINE)     # inline literal, role, literal block
ROW = re.compile(r"^\| `(?P<name>[a-z][a-z-]*)[^\n]*\|(?P<options>[^|\n]*)\|\s*$", re.MULTILINE)


def _text() -> str:
    return README.read_text(encoding="utf-8")


def _blocks(*languages: str) -> list[str]:
    """The README's fenced code blocks in these languages, in order."""
    return [m.group(2) for m in re.finditer(r"^```(\w*)\n(.*?)^```", _text(), re.MULTILINE | re.DOTALL)
            if m.group(1) in languages]


def _commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """Sub-command name -> its parser."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _options(parser: argparse.ArgumentParser) -> set[str]:
    """The long options a parser declares, --help aside."""
    return {o for a in parser._actions for o in a.option_strings if o.startswith("--") and o != "--help"}


def _readme_table() -> dict[str, set[str]]:
    """Sub-command -> the options the README's "Command line" table lists for it."""
    text = _text()
    section = text[text.index("## Command line"):]
    section = section[:section.index("\n## ")]
    return {m["name"]: set(re.findall(r"--[a-z][a-z0-9-]*", m["options"])) for m in ROW.finditer(section)}


def _tensegrid_lines() -> list[list[str]]:
    """The arguments of every ``tensegrid ...`` line in the README's sh/bash blocks, comments dropped."""
    return [shlex.split(line, comments=True)[1:] for block in _blocks("sh", "bash")
            for line in block.splitlines() if line.startswith("tensegrid ")]


def test_the_readme_table_lists_every_command_with_exactly_its_options() -> None:
    declared = {name: _options(p) for name, p in _commands(build_parser()).items()}
    listed = _readme_table()
    assert sorted(listed) == sorted(declared), "README rows vs `tensegrid --help` commands"
    differ = {name: {"not in the README": sorted(declared[name] - listed[name]),
                     "not in argparse": sorted(listed[name] - declared[name])}
              for name in declared if declared[name] != listed[name]}
    assert not differ, f"README's Command line table and argparse disagree: {differ}"


def test_the_readme_stays_short() -> None:
    assert len(_text()) < 8000


def test_every_readme_command_parses() -> None:
    lines = _tensegrid_lines()
    assert {argv[0] for argv in lines} >= RUN | {"identify", "diagnose", "convert", "plan"}
    for argv in lines:
        parser = build_parser(argv[0])
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:      # argparse printed why to stderr
            pytest.fail(f"README: `tensegrid {shlex.join(argv)}` does not parse (exit {exc.code})")
        assert callable(getattr(args, "func", None))


def test_the_fast_readme_commands_run(tmp_path: Path) -> None:
    """The README's simulate and check lines, in order, in a fresh folder (the check reads what simulate wrote)."""
    ran = 0
    for argv in _tensegrid_lines():
        if argv[0] in RUN:
            done = subprocess.run([sys.executable, "-m", "physics.cli", *argv], cwd=tmp_path, capture_output=True,
                                  text=True, timeout=300)
            assert done.returncode == 0, f"tensegrid {shlex.join(argv)}:\n{done.stdout}\n{done.stderr}"
            ran += 1
    assert ran == 2


def test_readme_python_examples_that_start_workers_are_guarded() -> None:
    """A dask pool or a process pool spawns processes that import the script: such an example needs
    ``if __name__ == "__main__":``."""
    blocks = _blocks("python")
    assert blocks
    for block in blocks:
        compile(block, "README.md", "exec")
        spawns = re.search(r"n_workers=[1-9]|workers=[1-9]|DaskPool|multiprocessing|ProcessPool", block)
        assert not spawns or 'if __name__ == "__main__":' in block, block


@pytest.mark.slow
def test_readme_python_examples_run_as_written(tmp_path: Path) -> None:
    for k, block in enumerate(_blocks("python")):
        script = tmp_path / f"example_{k}.py"
        script.write_text(block, encoding="utf-8")
        done = subprocess.run([sys.executable, script.name], cwd=tmp_path, capture_output=True, text=True,
                              timeout=900)
        assert done.returncode == 0, f"README python block {k}:\n{done.stderr[-3000:]}"


def test_help_is_plain_text_and_usage_shows_every_choice() -> None:
    parser = build_parser()
    assert not RST.search(parser.format_help())
    for name, sub in _commands(parser).items():
        text = sub.format_help()
        assert not RST.search(text), f"tensegrid {name} --help shows reStructuredText: {RST.search(text)}"
        usage = " ".join(sub.format_usage().split())
        for action in sub._actions:
            if action.choices is not None and action.option_strings and action.metavar is None:
                shown = "{" + ",".join(map(str, action.choices)) + "}"
                assert shown in usage, f"tensegrid {name}: {action.option_strings[0]} {shown} not in the usage line"


def test_identify_usage_names_the_active_decoder() -> None:
    identify = _commands(build_parser("identify"))["identify"]
    decoder = next(a for a in identify._actions if "--decoder" in a.option_strings)
    assert decoder.choices is not None and "active" in decoder.choices
    assert "active" in identify.format_usage()


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        build_parser("--version").parse_args(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.split() == ["tensegrid", version("tensegrid")]


def test_the_api_loss_default_is_the_command_line_default() -> None:
    from physics.trajectory_objective import TrajectoryObjective

    identify = _commands(build_parser("identify"))["identify"]
    cli_default = next(a.default for a in identify._actions if "--loss" in a.option_strings)
    assert inspect.signature(TrajectoryObjective).parameters["loss"].default == cli_default == "squared"
