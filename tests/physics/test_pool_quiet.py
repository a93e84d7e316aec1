"""A dask pool is quiet (physics.pool): no dashboard port warning while another cluster runs, and
nothing alarming at shutdown, whether the pool is closed (context manager) or left open until the
interpreter exits."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = '''
import numpy as np

from physics import FlopController, ParameterSpace, TrajectoryObjective, simulate

if __name__ == "__main__":
    space = ParameterSpace.t6()
    data = simulate(controller=FlopController(heading=0.0), duration=0.2)
    thetas = np.stack([space.nominal, space.replace(damping=190.0)])
    left_open = TrajectoryObjective(data, n_workers=2)      # never closed: the pool closes it at exit
    first = left_open.evaluate_batch(thetas)
    with TrajectoryObjective(data, n_workers=2) as objective:   # a second cluster while the first runs
        second = objective.evaluate_batch(thetas)
    assert first.status == second.status == ("ok", "ok"), (first, second)
    print("evaluated", first.errors.tolist(), second.errors.tolist())
'''

ALARMS = ("already in use", "lose scattered data", "Stream is closed", "StreamClosedError", "CommClosedError",
          "Traceback", "ERROR", "Exception")


@pytest.mark.slow
def test_two_local_clusters_run_and_shut_down_without_alarming_messages(tmp_path: Path) -> None:
    script = tmp_path / "two_pools.py"
    script.write_text(SCRIPT, encoding="utf-8")
    done = subprocess.run([sys.executable, script.name], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "evaluated" in done.stdout
    found = [alarm for alarm in ALARMS if alarm in done.stderr]
    assert not found, f"stderr says {found}:\n{done.stderr}"
