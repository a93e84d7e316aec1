"""docs/your-robot.md and docs/tutorial_your_robot.py cannot drift apart, nor from the command line.

The doc's ``tensegrid`` commands (its ``sh`` code blocks) are the script's, in the script's order, and
the real parser of each sub-command accepts them; the doc states the quick settings the script adds, and
every option it names in its prose is one some sub-command declares.
The slow test runs the script in its quick mode (it writes labelled mm, y-up CSVs with a jittered clock
and two dropped frames, then runs the commands) and checks each step's outputs.
"""
from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pandas as pd
import pytest

from physics.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "your-robot.md"
SCRIPT = ROOT / "docs" / "tutorial_your_robot.py"


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("tutorial_your_robot", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _doc_commands() -> list[list[str]]:
    """The arguments of every ``tensegrid ...`` line in the doc's ``sh`` blocks (``\\`` continues a line)."""
    blocks = re.findall(r"^```sh\n(.*?)^```", DOC.read_text(encoding="utf-8"), flags=re.S | re.M)
    assert blocks, "no ```sh block in docs/your-robot.md"
    commands = []
    for block in blocks:
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if words[:1] == ["tensegrid"]:
                commands.append(words[1:])
    return commands


def _parse(argv: list[str]) -> None:
    """Parse ``argv`` with the real ``tensegrid`` parser of its sub-command; fail with argparse's message."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            build_parser(argv[0]).parse_args(argv)
        except SystemExit:
            pytest.fail(f"tensegrid {shlex.join(argv)}: {err.getvalue().strip()}")


def test_the_doc_commands_are_the_scripts_and_the_parser_accepts_them() -> None:
    script = _script()
    default, quick = script.commands(), script.commands(quick=True)
    documented = _doc_commands()
    assert {c[0] for c in documented} == {c[0] for c in default}, "a step of the script is missing from the doc"
    positions = []
    for argv in documented:
        _parse(argv)
        assert argv in default, f"docs/your-robot.md runs `tensegrid {shlex.join(argv)}`, the script does not"
        positions.append(default.index(argv))
    assert positions == sorted(positions), "the doc shows the commands in another order than the script runs them"
    for plain, fast in zip(default, quick, strict=True):                       # quick = default + its settings
        _parse(fast)
        assert fast[:len(plain)] == plain and fast[len(plain):] in ([], script.QUICK_IDENTIFY, script.QUICK_DIAGNOSE)
    text = " ".join(DOC.read_text(encoding="utf-8").split())
    for settings in (script.QUICK_IDENTIFY, script.QUICK_DIAGNOSE):           # the doc states them
        assert shlex.join(settings) in text, shlex.join(settings)


def test_every_option_the_doc_names_exists() -> None:
    """Options named in the prose too (``--fix``, ``--held-out``, ...) are some sub-command's, or the script's."""
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    known = {o for parser in sub.choices.values() for a in parser._actions for o in a.option_strings}
    known |= {"--quick", "--out"}                                               # the script's own
    named = set(re.findall(r"(?<![\w-])--[a-z][a-z-]*", DOC.read_text(encoding="utf-8")))
    assert named and not named - known, f"docs/your-robot.md names options tensegrid lacks: {sorted(named - known)}"


@pytest.mark.slow
def test_the_tutorial_runs_from_csv_to_report(tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, str(SCRIPT), "--quick", "--out", str(tmp_path)], capture_output=True,
                         text=True, env=env, timeout=1500)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    script = _script()
    ran = [line[len("$ tensegrid "):] for line in out.stdout.splitlines() if line.startswith("$ tensegrid ")]
    assert ran == [shlex.join(argv) for argv in script.commands(quick=True)]

    # the CSV as a lab exports it: labelled markers, cable commands by their end markers, two frames dropped
    table = pd.read_csv(tmp_path / "flop0.csv")
    assert {"Time (s)", "A1:X", "F2:Z", "motor_A1_C1"} <= set(table.columns)
    assert len(table) == round(script.DURATION * 100) + 1 - len(script.DROPPED)
    expected = [*(f"flop{k}.nc" for k in range(3)),
                *(f"identify/{name}" for name in ("result.nc", "summary.txt", "report.html",
                                                  "observed_vs_predicted.png")),
                *(f"{replay}/{name}" for replay in ("replay", "replay-diagnosed")
                  for name in ("trajectory.nc", "replay.png", "replay.json")),
                *(f"diagnose/{name}" for name in ("report.txt", "report.html", "diagnosis.json", "model.json"))]
    for name in expected:
        assert (tmp_path / name).stat().st_size > 200, name
    assert {"best", "verdict"} <= set((tmp_path / "identify" / "summary.txt").read_text().split("\n", 1)[0].split())
    assert "open-loop error" in out.stdout and "verdict:" in (tmp_path / "diagnose" / "report.txt").read_text()
