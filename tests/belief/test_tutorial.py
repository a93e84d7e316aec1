"""The identification tutorial runs in its quick mode and writes its figures."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_tutorial_identify_quick(tmp_path) -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, str(ROOT / "docs" / "tutorial_identify.py"), "--quick", "--out",
                          str(tmp_path)], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "90 % region" in out.stdout and "m^2 mu" in out.stdout
    for name in ("posterior.png", "marginals.png", "error.png", "result.nc"):
        assert (tmp_path / name).stat().st_size > 1000, name


@pytest.mark.slow
def test_tutorial_identify_t6_quick(tmp_path) -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, str(ROOT / "docs" / "tutorial_identify.py"), "--quick", "--t6", "--out",
                          str(tmp_path)], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "E at nominal" in out.stdout and "posterior mean - θ*" in out.stdout
    for name in ("t6_marginals.png", "t6_error.png", "t6_result.nc"):
        assert (tmp_path / name).stat().st_size > 1000, name
