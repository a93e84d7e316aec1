"""What diagnose cannot do with a file (criticism.limits): a robot that never rests on the floor and
markers that jump get one named line each, before anything is written; --skip-checks overrides."""
from __future__ import annotations

from pathlib import Path

import pytest
import xarray as xr

from criticism.limits import LIMITS, diagnosis_limits
from physics import FlopController, simulate
from physics.checks import check_trajectory
from physics.cli import main
from physics.trajectory import save_trajectory


@pytest.fixture(scope="module")
def flop() -> xr.Dataset:
    return simulate(controller=FlopController(heading=0.0), duration=0.6)


def _never_rests(ds: xr.Dataset) -> xr.Dataset:
    """The same flop recorded from 0.3 s on, mid-motion (time starting at 0)."""
    cut = ds.sel(time=slice(0.3, None))
    return cut.assign_coords(time=cut["time"] - cut["time"][0])


def _jumping(ds: xr.Dataset) -> xr.Dataset:
    out = ds.copy(deep=True)
    out["nodes"].values[40, 2, 1] += 0.04
    return out


@pytest.mark.parametrize(("bad", "code"), [(_never_rests, "not-at-rest"), (_jumping, "jumps")])
def test_each_limit_names_what_the_diagnosis_cannot_do(flop: xr.Dataset, bad, code: str) -> None:
    assert diagnosis_limits(check_trajectory(flop, source="good.nc")) == []
    lines = diagnosis_limits(check_trajectory(bad(flop), source="bad.nc"))
    assert len(lines) == 1 and lines[0].startswith("bad.nc: diagnose cannot use this file: " + LIMITS[code])
    assert "Fix: " in lines[0]


def test_diagnose_stops_before_writing_and_skip_checks_goes_past(flop: xr.Dataset, tmp_path: Path, capsys) -> None:
    good = save_trajectory(flop, tmp_path / "good.nc")
    moving = save_trajectory(_never_rests(flop), tmp_path / "moving.nc")
    jumping = save_trajectory(_jumping(flop), tmp_path / "jumping.nc")
    out = tmp_path / "d"
    assert main(["diagnose", str(moving), str(jumping), str(good), "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"{moving}: diagnose cannot use this file: the robot does not start at rest" in err
    assert f"{jumping}: diagnose cannot use this file: markers jump" in err
    assert "--skip-checks" in err and not out.exists()
    code = main(["diagnose", str(moving), str(good), "--out", str(out), "--skip-checks", "--budget", "1"])
    err = capsys.readouterr().err                # past the checks: the next validation (a bad budget) speaks
    assert code == 2 and "budget >= 2" in err and "diagnose cannot use" not in err
