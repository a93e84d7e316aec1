"""The data checks (physics.checks, ``tensegrid check``): each way a plausible-looking file can be wrong gives
its named finding with the right severity; a clean file gives none; identify and diagnose stop on errors."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import xarray as xr

from physics import FlopController, save_trajectory, simulate
from physics.checks import DataCheckError, check_file, check_trajectory, require_clean
from physics.cli import main
from physics.ground import ground_plane

PERMUTE_1_2 = [0, 2, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11]


@pytest.fixture(scope="module")
def short() -> xr.Dataset:
    """0.5 s of the nominal robot resting 0.2 s, then starting a flop toward +x (noise-free)."""
    return simulate(controller=FlopController(heading=0.0), duration=0.5)


def _with_nodes(ds: xr.Dataset, values: np.ndarray) -> xr.Dataset:
    out = ds.copy()
    out["nodes"] = xr.DataArray(values, dims=ds["nodes"].dims, attrs={})
    return out


def _millimetres(ds: xr.Dataset) -> xr.Dataset:
    return _with_nodes(ds, ds["nodes"].values * 1000.0)


def _centimetres(ds: xr.Dataset) -> xr.Dataset:
    return _with_nodes(ds, ds["nodes"].values * 100.0)


def _milliseconds(ds: xr.Dataset) -> xr.Dataset:
    return ds.assign_coords(time=("time", ds["time"].values * 1000.0))


def _y_up(ds: xr.Dataset) -> xr.Dataset:
    return _with_nodes(ds, ds["nodes"].values[..., [0, 2, 1]])


def _z_down(ds: xr.Dataset) -> xr.Dataset:
    return _with_nodes(ds, ds["nodes"].values * np.array([1.0, -1.0, -1.0]))


def _swapped_between_rods(ds: xr.Dataset) -> xr.Dataset:
    return ds.isel(node=PERMUTE_1_2).assign_coords(node=range(12))


def _swapped_within_rod(ds: xr.Dataset) -> xr.Dataset:
    return ds.isel(node=[1, 0, *range(2, 12)]).assign_coords(node=range(12))


def _swapped_from_mid_run(ds: xr.Dataset) -> xr.Dataset:
    values = ds["nodes"].values.copy()
    values[35:] = values[35:, PERMUTE_1_2]
    return _with_nodes(ds, values)


def _rotation_y(degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    return np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])


def _tilted(ds: xr.Dataset) -> xr.Dataset:
    return _with_nodes(ds, ds["nodes"].values @ _rotation_y(3.0).T)


def _raised(ds: xr.Dataset) -> xr.Dataset:
    return _with_nodes(ds, ds["nodes"].values + np.array([0.0, 0.0, 0.5]))


def _dropouts(ds: xr.Dataset) -> xr.Dataset:
    values = ds["nodes"].values.copy()
    values[10:14] = np.nan
    values[30, 3] = np.nan
    return _with_nodes(ds, values)


def _jump(ds: xr.Dataset) -> xr.Dataset:
    values = ds["nodes"].values.copy()
    values[25, 5] += 0.3
    return _with_nodes(ds, values)


def _glitch(ds: xr.Dataset) -> xr.Dataset:
    values = ds["nodes"].values.copy()
    values[30, 7, 0] += 0.03                  # 3 cm for one sample: 3 m/s, slower than MAX_NODE_SPEED
    return _with_nodes(ds, values)


def _moving(ds: xr.Dataset) -> xr.Dataset:
    values = ds["nodes"].values.copy()
    values += np.linspace(0.0, 0.3, len(values))[:, None, None] * np.array([1.0, 0.0, 0.0])
    return _with_nodes(ds, values)             # sliding 0.6 m/s from the first sample: never at rest


def _jitter(ds: xr.Dataset) -> xr.Dataset:
    shift = np.random.default_rng(0).uniform(-2e-4, 2e-4, ds.sizes["time"])
    return ds.assign_coords(time=("time", ds["time"].values + shift))


def _controls_in_mm(ds: xr.Dataset) -> xr.Dataset:
    return ds.assign(controls=ds["controls"] * 1000.0)


def _controls_are_cable_lengths(ds: xr.Dataset) -> xr.Dataset:
    nodes = ds["nodes"].values
    ends = ds["end_a"].values, ds["end_b"].values
    lengths = np.linalg.norm(nodes[:, ends[0]] - nodes[:, ends[1]], axis=-1)
    return ds.assign(controls=(("time", "cable"), lengths))


BAD: dict[str, tuple[Callable[[xr.Dataset], xr.Dataset], str, str]] = {
    "millimetres": (_millimetres, "length-units", "error"),
    "centimetres": (_centimetres, "length-units", "error"),
    "milliseconds": (_milliseconds, "time-units", "error"),
    "y up": (_y_up, "up-axis", "error"),
    "z down": (_z_down, "up-axis", "error"),
    "ends swapped between rods": (_swapped_between_rods, "rod-ends-swapped", "error"),
    "ends of one rod swapped": (_swapped_within_rod, "cable-ends", "error"),
    "labels swapped mid-run": (_swapped_from_mid_run, "rod-not-rigid", "error"),
    "floor 0.5 m below z = 0": (_raised, "ground-height", "error"),
    "controls in millimetres": (_controls_in_mm, "controls-units", "error"),
    "tilted 3 deg": (_tilted, "ground-tilt", "warning"),
    "NaN dropouts": (_dropouts, "dropouts", "warning"),
    "a jump": (_jump, "jumps", "warning"),
    "a one-sample glitch": (_glitch, "jumps", "warning"),
    "moving from the start": (_moving, "not-at-rest", "warning"),
    "jittered time": (_jitter, "time-jitter", "warning"),
    "controls are cable lengths": (_controls_are_cable_lengths, "controls-semantics", "warning"),
}


def test_a_clean_simulated_file_has_no_errors_and_no_warnings(short) -> None:
    report = check_trajectory(short)
    assert report.errors == () and report.warnings == (), report.lines()
    assert {"sampling", "rod-length", "ground", "controls"} <= set(report.codes)
    assert report.rod_length == pytest.approx(1.74, abs=1e-3)
    assert report.sample_interval == pytest.approx(0.01)
    assert report.length_scale == report.time_scale == 1.0


@pytest.mark.parametrize("name", list(BAD))
def test_each_bad_input_gives_its_named_finding(short, name: str) -> None:
    make, code, severity = BAD[name]
    report = check_trajectory(make(short), source="bad.nc")
    found = report.finding(code)
    assert found is not None, report.lines()
    assert found.severity == severity and found.message and found.fix
    if severity == "error":     # one mistake, one error
        assert [f.code for f in report.errors] == [code], report.lines()
    else:
        assert report.errors == (), report.lines()
    assert all(line.startswith("bad.nc: ") and "\n" not in line for line in report.lines())


def test_dropped_frames_are_told_apart_from_single_missing_nodes(short) -> None:
    """Two whole frames lost (a dropped frame: every node NaN, controls too) read as such, with no
    "node missing most" that every node shares; a node missing alone is counted and named apart."""
    values = short["nodes"].values.copy()
    values[[20, 35]] = np.nan
    dropped = _with_nodes(short, values)
    dropped["controls"] = dropped["controls"].where(~dropped["time"].isin(dropped["time"].values[[20, 35]]))
    message = check_trajectory(dropped).finding("dropouts").message
    assert "2 frames missing entirely (all nodes NaN), 0 frames with only some nodes missing" in message
    assert "missing most" not in message and "NaN;" not in message
    values[40, 7] = np.nan
    message = check_trajectory(_with_nodes(short, values)).finding("dropouts").message
    assert "2 frames missing entirely (all nodes NaN), 1 frame with only some nodes missing" in message
    assert "node 7 is missing most often (1 of those samples)" in message


def test_a_file_without_encoder_readings_is_told_they_would_measure_the_actuator(short) -> None:
    """Without rest_length (or with none finite) an info finding says the readings would let the actuator
    be measured directly; it changes nothing else, and a file with readings does not get it."""
    assert check_trajectory(short).finding("rest-length-missing") is None
    for bare in (short.drop_vars("rest_length"), short.assign(rest_length=short["rest_length"] * np.nan)):
        report = check_trajectory(bare, source="bare.nc")
        found = report.finding("rest-length-missing")
        assert found is not None and found.severity == "info", report.lines()
        assert "encoder readings" in found.message and "measured directly from commands" in found.fix
        assert report.errors == () and report.warnings == ()
        assert set(report.codes) - {"rest-length-missing"} == set(check_trajectory(short).codes)


def test_the_units_are_named_and_converted_before_the_other_checks(short) -> None:
    mm = check_trajectory(_millimetres(short))
    assert mm.length_scale == 1e-3 and mm.rod_length == pytest.approx(1.74, abs=1e-3)
    assert "millimetres" in mm.errors[0].message and "* 0.001" in mm.errors[0].fix
    ms = check_trajectory(_milliseconds(short))
    assert ms.time_scale == 1e-3 and ms.sample_interval == pytest.approx(0.01)
    assert "milliseconds" in ms.errors[0].message
    swapped = check_trajectory(_swapped_between_rods(short)).errors[0]
    assert "0-2, 1-3" in swapped.fix and str(PERMUTE_1_2) in swapped.fix
    assert "rod(s) [0]" in check_trajectory(_swapped_within_rod(short)).errors[0].fix


def test_the_ground_plane_of_a_tilted_trajectory(short) -> None:
    level = ground_plane(short)
    assert level is not None and level.tilt_deg < 0.01 and level.height == pytest.approx(0.06, abs=1e-3)
    tilted = ground_plane(_tilted(short))
    assert tilted is not None and tilted.tilt_deg == pytest.approx(3.0, abs=0.01)
    np.testing.assert_allclose(tilted.normal, _rotation_y(3.0) @ [0.0, 0.0, 1.0], atol=1e-6)
    assert tilted.residual < 1e-6 and len(tilted.nodes) == 3


def test_a_file_the_loader_refuses_still_gets_the_checks(tmp_path, short) -> None:
    """A timestamp 3 ms off a 100 Hz clock (30 % of the interval, beyond the loader's snapping
    tolerance): the loader refuses the file, and the checks still describe it."""
    path = tmp_path / "jitter.nc"
    time = short["time"].values.copy()
    time[5] += 3e-3
    _jitter(short).assign_coords(time=("time", time)).to_netcdf(path)
    report = check_file(path)
    assert report.codes[0] == "format" and "only deviations up to 25%" in report.errors[0].message
    assert report.finding("time-jitter") is not None
    missing = check_file(tmp_path / "missing.nc")
    assert missing.codes == ("format",) and "does not exist" in missing.errors[0].message


def test_require_clean_raises_one_line_per_error(short) -> None:
    with pytest.raises(DataCheckError) as caught:
        require_clean([short, _millimetres(short), _y_up(short)], ["a.nc", "b.nc", "c.nc"])
    lines = str(caught.value).splitlines()
    assert lines[0].startswith("b.nc: error length-units") and lines[1].startswith("c.nc: error up-axis")
    assert len(lines) == 3 and "--skip-checks" in lines[-1]
    assert len(require_clean([short], ["a.nc"])) == 1


@pytest.fixture(scope="module")
def files(short, tmp_path_factory) -> dict[str, str]:
    folder = tmp_path_factory.mktemp("check")
    return {"good": str(save_trajectory(short, folder / "good.nc")),
            "mm": str(save_trajectory(_millimetres(short), folder / "mm.nc"))}


def test_the_check_command_exits_2_on_an_error_and_0_on_a_clean_file(files, capsys) -> None:
    assert main(["check", files["good"]]) == 0
    out = capsys.readouterr().out
    assert "info rod-length" in out and "0 error(s)" in out
    assert main(["check", files["good"], files["mm"]]) == 2
    out = capsys.readouterr().out
    assert f"{files['mm']}: error length-units" in out and "Fix: convert to metres" in out
    assert "1 error(s) in 1 file(s)" in out
    assert main(["check", "--quiet", files["good"]]) == 0
    assert "info" not in capsys.readouterr().out


def test_identify_stops_on_the_checks_before_any_evaluation(files, tmp_path, capsys) -> None:
    out = tmp_path / "run"
    code = main(["identify", files["mm"], "--preset", "bo", "--budget", "3", "--out", str(out), "--no-progress",
                 "--no-next"])
    assert code == 2
    err = capsys.readouterr().err
    assert f"tensegrid identify: {files['mm']}: error length-units" in err and "--skip-checks" in err
    assert not out.exists()                  # nothing written, nothing evaluated


def test_diagnose_stops_on_the_checks(files, tmp_path, capsys) -> None:
    assert main(["diagnose", files["mm"], files["good"], "--out", str(tmp_path / "d"), "--no-progress"]) == 2
    assert "error length-units" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("command", ["identify", "diagnose"])
def test_skip_checks_is_an_option_of_identify_and_diagnose(command: str, capsys) -> None:
    with pytest.raises(SystemExit):
        main([command, "--help"])
    assert "--skip-checks" in capsys.readouterr().out


def test_testbed_files_slope_warns_of_the_tilt_nominal_does_not() -> None:
    pytest.importorskip("pybullet")
    from testbed.datasets import cached_dataset

    for name, tilted in (("slope", True), ("nominal", False)):
        for path in cached_dataset(name, 0, noise=0.0002).values():
            report = check_file(path)
            assert report.errors == (), report.lines()
            assert [f.code for f in report.warnings] == (["ground-tilt"] if tilted else []), report.lines()
            assert report.ground is not None
            assert report.ground.tilt_deg == (pytest.approx(3.0, abs=0.2) if tilted else pytest.approx(0.0, abs=0.2))
