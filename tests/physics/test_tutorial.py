"""The physics tutorial runs (quick mode) and says what it claims."""
from __future__ import annotations

import runpy
from pathlib import Path

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_tutorial_simulate_runs(tmp_path):
    tutorial = runpy.run_path(str(DOCS / "tutorial_simulate.py"))
    result = tutorial["main"](quick=True, out=str(tmp_path))
    assert result["png"].exists() and result["png"].stat().st_size > 10_000
    assert result["e_off"] > result["e_true"]
    assert result["moved"] > 0.1
