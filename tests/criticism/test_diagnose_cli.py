"""``tensegrid diagnose`` takes the prior box like identify, prints a run-time estimate and a line per stage
even with --no-progress (issue 65, item 3); the heavy loop is replaced where only the plumbing is tested."""
from __future__ import annotations

import numpy as np
import pytest

import criticism.cli as cli
from criticism.diagnose import DiagnoseConfig, Diagnosis
from criticism.run_estimate import Announcer, estimate_line, evaluations
from physics import FlopController, ParameterSpace, TrajectoryObjective, save_trajectory, simulate
from physics.cli import main
from physics.effects import catalog


@pytest.fixture(scope="module")
def two_files(tmp_path_factory) -> list[str]:
    """Two short nominal flops, saved as netCDF."""
    theta = ParameterSpace.t6().nominal
    folder = tmp_path_factory.mktemp("data")
    flops = [simulate(theta, controller=FlopController(heading=h), duration=0.3) for h in (0.0, 1.5708)]
    return [str(save_trajectory(ds, folder / f"{k}.nc")) for k, ds in enumerate(flops)]


def test_diagnose_runs_in_the_box_given_and_says_what_it_does(tmp_path, two_files, monkeypatch, capsys) -> None:
    """--bounds reaches criticism.diagnose as its space, the box is printed, and the stage lines go to stdout."""
    seen = {}

    def fake(data, *, held_out, effects, config, journal_dir, options, progress, space, say):
        seen.update(space=space, progress=progress)
        with Announcer(say).stage("mismatch stage"):
            pass
        raise SystemExit(7)          # the report is not under test

    monkeypatch.setattr(cli, "diagnose", fake)
    with pytest.raises(SystemExit):
        main(["diagnose", *two_files, "--out", str(tmp_path / "out"), "--no-progress", "--skip-checks",
              "--bounds", "rod_length=1.5:1.9", "--nominal", "damping=55"])
    space = seen["space"]
    assert (space["rod_length"].lower, space["rod_length"].upper) == (1.5, 1.9)
    assert space["damping"].nominal == 55 and seen["progress"] is False
    out = capsys.readouterr().out
    assert "prior box: 2 of 15 parameters differ from the default" in out
    assert "diagnose: mismatch stage: started" in out and "diagnose: mismatch stage: done in" in out


def test_the_box_holds_as_effects_join_the_model(two_files) -> None:
    """criticism.diagnose's stages build their models with with_effects: the T6 box must survive it."""
    import xarray as xr
    space = ParameterSpace.t6(bounds={"rod_length": (1.5, 1.9)})
    with TrajectoryObjective([xr.open_dataset(two_files[0])], space=space, n_workers=1) as objective:
        extended = objective.with_effects(catalog()[:1]).with_effects(catalog()[:2])
    assert extended.space["rod_length"].upper == 1.9
    assert extended.space.dim == 15 + sum(len(e.parameters()) for e in catalog()[:2])


def test_the_estimate_counts_identifications_fits_and_screens() -> None:
    """More passes or a larger budget cost more; the line states evaluations, seconds and minutes."""
    base = evaluations(DiagnoseConfig(), dim=15, n_effects=5)
    assert evaluations(DiagnoseConfig(budget=80), dim=15, n_effects=5) == base + 3 * 40
    assert evaluations(DiagnoseConfig(passes=3), dim=15, n_effects=5) > base
    assert evaluations(DiagnoseConfig(mismatch=None), dim=15, n_effects=5) < base
    line = estimate_line(1200, 0.5)
    assert "1200 evaluations" in line and "about 10 min on this machine" in line and "rough" in line


def test_diagnose_prints_the_estimate_and_every_stage(two_files) -> None:
    """The library loop, shrunk to one cheap pass, says the estimate then each stage's start and end."""
    import xarray as xr

    from criticism.diagnose import diagnose
    lines: list[str] = []
    data = [xr.open_dataset(f) for f in two_files]
    result = diagnose(data, effects=[], config=DiagnoseConfig(passes=1, budget=6, candidates=32, horizon=5,
                                                              mismatch=None, measure_at_rest=False),
                      n_workers=1, progress=False, say=lines.append)
    assert isinstance(result, Diagnosis)
    assert lines[0].startswith("diagnose: estimate: at most about") and "min on this machine" in lines[0]
    stages = [line for line in lines[1:] if ": started" in line]
    assert [s.split(": ")[1] for s in stages] == ["actuator reading", "first model", "identification 0",
                                                  "pass 1 criticism"]
    assert sum(": done in" in line for line in lines) == 4
    assert result.actuator is not None and result.actuator.effect is None   # the motor's own readings: kept
    assert np.isfinite(result.passes[0].theta).all()


def test_diagnose_prints_warnings_as_plain_notes(tmp_path, two_files, monkeypatch, capsys) -> None:
    """A budget warning and numpy's all-NaN warning raised during the run reach the terminal as one
    'note:' line each, without Python's 'FILE:LINE: Category:' and source line."""
    import warnings

    from belief.errors import BudgetWarning

    def fake(data, **kwargs):
        warnings.warn("6 successful evaluations for a 15-dimensional search", BudgetWarning, stacklevel=2)
        np.nanmax(np.full((2, 3), np.nan), axis=1)
        raise SystemExit(7)          # the report is not under test

    monkeypatch.setattr(cli, "diagnose", fake)
    with pytest.raises(SystemExit):
        main(["diagnose", *two_files, "--out", str(tmp_path / "out"), "--no-progress", "--skip-checks"])
    err = capsys.readouterr().err
    assert "tensegrid diagnose: note: 6 successful evaluations for a 15-dimensional search\n" in err
    assert "tensegrid diagnose: note: All-NaN slice encountered (raised at " in err
    assert "Warning:" not in err and "np.nanmax(" not in err and "warnings.warn(" not in err


def test_phases_of_a_recording_with_dropped_frames_raise_no_warning(two_files) -> None:
    """A dropped frame (nodes and commands NaN) once made phases() warn of an all-NaN slice; the
    command held across it still shows a change made during the gap."""
    import warnings

    import xarray as xr

    from criticism.residuals import phases

    ds = xr.open_dataset(two_files[0]).load()
    controls = ds["controls"].values
    step = int(np.flatnonzero(np.abs(np.diff(controls, axis=0)).max(axis=1) > 1e-9)[0]) + 1     # first change
    gappy = ds.copy(deep=True)
    gappy["controls"].values[step] = np.nan
    gappy["nodes"].values[step] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        labels = phases(gappy)
    assert labels[step + 1] == "actuating" and (labels == phases(ds)).sum() >= len(labels) - 1
