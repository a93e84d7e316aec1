"""``tensegrid plan`` and ``tensegrid probe`` on a tiny belief: files, figure, typed errors as exit code 2."""
from __future__ import annotations

import json
from importlib.metadata import entry_points

from physics.cli import main


def test_commands_are_registered_plugins() -> None:
    names = {ep.name: ep.value for ep in entry_points(group="tensegrid.commands")}
    assert names.get("plan") == "planners.cli:register_plan" and names.get("probe") == "planners.cli:register_probe"


def test_plan_writes_record_and_figure(make_belief, tmp_path, capsys) -> None:
    path = tmp_path / "b.nc"
    make_belief(2).save(path)
    code = main(["plan", str(path), "--goal", "1.5", "0.0", "--samples", "2", "--steps", "1", "--out",
                 str(tmp_path / "out")])
    assert code == 0, capsys.readouterr().err
    record = json.loads((tmp_path / "out" / "plan.json").read_text())
    assert len(record["runs"]["robust"]["steps"]) == 1 and record["level"] == 0.5 and record["learn"] is True
    assert record["runs"]["robust"]["steps"][0]["entropy"] is None       # no update after the last flop
    assert (tmp_path / "out" / "plan.png").stat().st_size > 5000
    assert "robust:" in capsys.readouterr().out


def test_plan_rejects_a_bad_goal_and_level(make_belief, tmp_path, capsys) -> None:
    path = tmp_path / "b.nc"
    make_belief(2).save(path)
    assert main(["plan", str(path), "--goal", "100", "0", "--out", str(tmp_path / "o")]) == 2
    assert "give a nearer goal" in capsys.readouterr().err
    assert main(["plan", str(path), "--goal", "2", "0", "--level", "0", "--out", str(tmp_path / "o")]) == 2
    assert "level α must be a number in (0, 1]" in capsys.readouterr().err


def test_tutorial_plan_quick(tmp_path) -> None:
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, PYTHONPATH=str(root) + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, str(root / "docs" / "tutorial_plan.py"), "--quick", "--out", str(tmp_path)],
                         capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "robust plan:" in out.stdout and "probe 1:" in out.stdout
    for name in ("plan.png", "probe.png"):
        assert (tmp_path / name).stat().st_size > 5000, name
