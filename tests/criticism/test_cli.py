"""``tensegrid diagnose``: registered by criticism through the command-line plugin group; usage errors."""
from __future__ import annotations

from importlib.metadata import entry_points

import pytest

from criticism.cli import register_diagnose
from physics import FlopController, ParameterSpace, save_trajectory, simulate
from physics.cli import main


@pytest.fixture(scope="module")
def two_files(tmp_path_factory) -> list[str]:
    """Two short SUPERball trajectories (same θ, flops toward +x and +y), saved as netCDF."""
    theta = ParameterSpace.t6().sample(1, seed=3)[0]
    folder = tmp_path_factory.mktemp("data")
    flops = [simulate(theta, controller=FlopController(heading=h), duration=0.4) for h in (0.0, 1.5708)]
    return [str(save_trajectory(ds, folder / f"{k}.nc")) for k, ds in enumerate(flops)]


def test_the_diagnose_command_is_criticism_s_plugin() -> None:
    found = {ep.name: ep for ep in entry_points(group="tensegrid.commands")}
    assert found["diagnose"].value == "criticism.cli:register_diagnose"
    assert found["diagnose"].load() is register_diagnose


def test_diagnose_usage_errors_name_the_fix(tmp_path, two_files, capsys) -> None:
    """Bad input to ``tensegrid diagnose`` fails before any identification, saying what to do."""
    assert main(["diagnose", *two_files, "--effects", "magic", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr()
    assert "unknown effect(s) ['magic']" in err.err and "samples at 100 Hz" in err.out
    assert main(["diagnose", *two_files, "--held-out", "0", "1", "--out", str(tmp_path)]) == 2
    assert "some (not all)" in capsys.readouterr().err
    assert main(["diagnose", str(tmp_path / "missing.nc"), "--out", str(tmp_path)]) == 2
    assert "does not exist" in capsys.readouterr().err
