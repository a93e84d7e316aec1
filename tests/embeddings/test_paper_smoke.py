"""benchmarks/paper.py --smoke: every method and peer runs on a tiny budget and writes its outputs."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_paper_comparison_smoke(tmp_path) -> None:
    pytest.importorskip("cma")
    pytest.importorskip("botorch")
    env = {**os.environ, "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "paper.py"), "--smoke", "--out", str(tmp_path),
                           "--cache", str(tmp_path / "cache")], capture_output=True, text=True, env=env, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    rows = [json.loads(line) for line in (tmp_path / "paper.jsonl").read_text().splitlines()]
    methods = {"random-15", "bo-15", "bo-gn", "rembo-5", "vae-5", "ae-dyn-5", "ae-dyn-prior-5", "active-5", "ae-cf-5",
               "ae-cf-bo", "ae-cf-bo-gn", "cma-es", "botorch"}
    assert {r["method"] for r in rows} == methods and len(rows) == len(methods)
    for row in rows:
        # the Gauss-Newton step's 15 + 4 evaluations are counted; the presets' minimum budget keeps the
        # search before it (ae-cf-bo-gn: 3 latent + 1 full-space; bo-gn: the 2 the posterior needs)
        n = {"ae-cf-bo-gn": 3 + 1 + 15 + 4, "bo-gn": 2 + 15 + 4}.get(row["method"], 5)
        assert len(row["errors"]) == n and len(row["heldout"]) == n and len(row["param_error_pct"]) == 15
        assert all(b >= a for a, b in zip(row["seconds"], row["seconds"][1:]))
    assert sum("verdict" in r for r in rows) == 11                # the belief methods report verdicts
    assert "parameter error of the final best" in done.stdout and "held-out E" in done.stdout
    assert "ae-cf-bo-gn against each method" in done.stdout        # the paired table
    assert (tmp_path / "paper_heldout.png").stat().st_size > 0
