"""``tensegrid simulate``: writes a valid trajectory and a picture; bad input is a clear error."""
from __future__ import annotations

import subprocess
import sys

from physics import load_trajectory
from physics.cli import main


def test_simulate_writes_trajectory_and_picture(tmp_path, capsys):
    code = main(["simulate", "--out", str(tmp_path), "--flops", "0", "--duration", "0.3",
                 "--theta", "damping=190", "--noise", "0.001", "--seed", "3"])
    assert code == 0
    ds = load_trajectory(tmp_path / "trajectory.nc")
    assert ds.sizes["time"] == 31
    assert float(ds.theta.sel(parameter="damping")) == 190.0
    assert (tmp_path / "trajectory.png").stat().st_size > 10_000
    assert "wrote" in capsys.readouterr().out


def test_bad_input_exits_2_with_a_message(tmp_path, capsys):
    assert main(["simulate", "--out", str(tmp_path), "--theta", "densty=300"]) == 2
    assert "Unknown parameter name(s) ['densty']" in capsys.readouterr().err
    assert main(["simulate", "--out", str(tmp_path), "--theta", "damping"]) == 2
    assert "NAME=VALUE" in capsys.readouterr().err
    assert not (tmp_path / "trajectory.nc").exists()


def test_console_script_lists_its_commands():
    out = subprocess.run([sys.executable, "-m", "physics.cli", "--help"], capture_output=True, text=True)
    assert out.returncode == 0
    assert "simulate" in out.stdout and "identify" in out.stdout
