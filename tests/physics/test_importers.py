"""CSV to trajectory (physics.importers, ``tensegrid convert``): units, the up-axis rotation, the clock, errors."""
from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from physics import FlopController, simulate
from physics.checks import check_file
from physics.cli import main
from physics.errors import ImportFormatError, TimestampError
from physics.geometry import CABLE_NAMES
from physics.importers import UP_AXES, from_csv, to_csv, up_rotation
from physics.trajectory import load_trajectory


@pytest.fixture(scope="module")
def flop() -> xr.Dataset:
    """0.5 s of the nominal robot starting a flop, at 100 Hz."""
    return simulate(controller=FlopController(heading=0.0), duration=0.5, settle=1.0)


def _lab_csv(ds: xr.Dataset, path: Path, rows: np.ndarray | None = None, time_shift: np.ndarray | None = None) -> Path:
    """The CSV a y-up lab would export, written without physics.importers: millimetres, milliseconds,
    file axes (x, y, z) = world (x, z, -y), i.e. y up and the frame right-handed."""
    nodes = ds["nodes"].values * 1000.0
    file_xyz = np.stack([nodes[..., 0], nodes[..., 2], -nodes[..., 1]], axis=-1)
    columns = {"time": ds["time"].values * 1000.0 + (0.0 if time_shift is None else time_shift)}
    for n in range(12):
        for a, axis in enumerate("xyz"):
            columns[f"node{n}_{axis}"] = file_xyz[:, n, a]
    for c, cable in enumerate(CABLE_NAMES):
        columns[cable] = ds["controls"].values[:, c] * 1000.0
        columns[f"rest_{cable}"] = ds["rest_length"].values[:, c] * 1000.0
    table = pd.DataFrame(columns)
    (table if rows is None else table.iloc[rows]).to_csv(path, index=False)
    return path


def test_csv_round_trip_through_the_command_line(tmp_path: Path, flop: xr.Dataset, capsys) -> None:
    csv = _lab_csv(flop, tmp_path / "lab.csv")
    out = tmp_path / "lab.nc"
    assert main(["convert", str(csv), str(out), "--units", "mm", "--up", "y", "--time-unit", "ms"]) == 0
    assert "checks: 0 error(s)" in capsys.readouterr().out
    back = load_trajectory(out)
    for var in ("nodes", "controls", "rest_length"):
        np.testing.assert_allclose(back[var].values, flop[var].values, rtol=0, atol=1e-9, err_msg=var)
    np.testing.assert_allclose(back["time"].values, flop["time"].values, rtol=0, atol=1e-9)
    assert check_file(out).errors == ()
    assert main(["check", str(out)]) == 0


def test_the_up_rotation_is_proper_and_takes_up_to_z() -> None:
    for up in UP_AXES:
        rotation = up_rotation(up)
        np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-15)
        assert np.linalg.det(rotation) == pytest.approx(1.0)
        file_up = np.zeros(3)
        file_up["xyz".index(up[-1])] = -1.0 if up.startswith("-") else 1.0
        np.testing.assert_allclose(rotation @ file_up, [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(up_rotation("y") @ [1.0, 2.0, 3.0], [1.0, -3.0, 2.0])   # (x, -z, y)


@pytest.mark.parametrize("units, up, time_unit", [("m", "z", "s"), ("cm", "-x", "us"), ("mm", "-z", "ms")])
def test_to_csv_and_from_csv_are_inverse(tmp_path: Path, flop: xr.Dataset, units: str, up: str,
                                         time_unit: str) -> None:
    path = to_csv(flop, tmp_path / "t.csv", units=units, up=up, time_unit=time_unit)
    back = from_csv(path, units=units, up=up, time_unit=time_unit, length_reference="encoder")
    np.testing.assert_allclose(back["nodes"].values, flop["nodes"].values, atol=1e-9)
    assert back.attrs["length_reference"] == "encoder" and "velocities" not in back


def test_jittered_rows_and_dropped_rows_become_the_clock_and_nan_rows(tmp_path: Path, flop: xr.Dataset) -> None:
    keep = np.setdiff1d(np.arange(flop.sizes["time"]), [12, 30, 31])
    shift = np.random.default_rng(0).uniform(-0.2, 0.2, flop.sizes["time"])        # ±0.2 ms
    back = from_csv(_lab_csv(flop, tmp_path / "gaps.csv", rows=keep, time_shift=shift), units="mm", up="y",
                    time_unit="ms")
    missing = ~np.isfinite(back["nodes"].values).all(axis=(1, 2))
    np.testing.assert_array_equal(np.flatnonzero(missing), [12, 30, 31])
    np.testing.assert_allclose(back["nodes"].values[keep], flop["nodes"].values[keep], atol=1e-9)
    assert "100 Hz clock" in back.attrs["clock"]
    far = np.zeros(flop.sizes["time"])
    far[9] = 4.0                                                                     # 40 % of 10 ms
    with pytest.raises(TimestampError, match="only deviations up to 25% are snapped"):
        from_csv(_lab_csv(flop, tmp_path / "late.csv", time_shift=far), units="mm", up="y", time_unit="ms")


def test_layout_errors_are_typed_one_line_and_name_the_fix(tmp_path: Path, flop: xr.Dataset) -> None:
    path = _lab_csv(flop, tmp_path / "lab.csv")
    table = pd.read_csv(path)
    table.drop(columns=["c00_04", "c07_09"]).to_csv(tmp_path / "partial.csv", index=False)
    table.drop(columns=list(CABLE_NAMES)).to_csv(tmp_path / "nocontrols.csv", index=False)
    table.assign(node3_x="lost").to_csv(tmp_path / "text.csv", index=False)
    cases = [
        (tmp_path / "partial.csv", {}, "control columns missing: c00_04, c07_09"),
        (tmp_path / "nocontrols.csv", {}, "no control column"),
        (tmp_path / "text.csv", {}, "a node cell is not a number"),
        (path, {"units": "inch"}, "units must be one of m, cm, mm"),
        (path, {"up": "w"}, "up must be one of"),
        (path, {"time_unit": "min"}, "time_unit must be one of"),
        (tmp_path / "none.csv", {}, "does not exist"),
    ]
    for csv, options, match in cases:
        with pytest.raises(ImportFormatError, match=match) as info:
            from_csv(csv, **options)
        assert "\n" not in str(info.value)


def test_convert_never_overwrites_or_half_writes(tmp_path: Path, flop: xr.Dataset, capsys) -> None:
    csv = _lab_csv(flop, tmp_path / "lab.csv")
    out = tmp_path / "kept.nc"
    out.write_text("precious")
    assert main(["convert", str(csv), str(out), "--units", "mm", "--up", "y", "--time-unit", "ms"]) == 2
    assert out.read_text() == "precious" and "pass --force" in capsys.readouterr().err
    assert main(["convert", str(csv), str(tmp_path), "--units", "mm"]) == 2
    fresh = tmp_path / "fresh.nc"
    with pytest.raises(SystemExit):                                                  # argparse refuses the choice
        main(["convert", str(csv), str(fresh), "--units", "inch"])
    assert not fresh.exists()
    assert main(["convert", str(csv), str(fresh), "--up", "y", "--time-unit", "ms"]) == 2    # mm read as metres
    printed = capsys.readouterr()
    assert "hint: the CSV's lengths look like mm: convert again with --units mm." in printed.out
    assert f"convert again with: tensegrid convert {csv} {fresh} --units mm --up y --time-unit ms" in printed.err
    assert not fresh.exists()                                                        # nothing written on an error
    assert main(["convert", str(csv), str(fresh), "--units", "mm", "--up", "y", "--time-unit", "ms", "--force"]) == 0
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".partial")] == []


def test_the_documented_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    text = (Path(__file__).resolve().parents[2] / "docs" / "data-format.md").read_text()
    section = text.split("## Converting a CSV", 1)[1]
    python = section.split("```python\n", 1)[1].split("```", 1)[0]
    shell = section.split("```sh\n", 1)[1].split("```", 1)[0].strip().splitlines()
    monkeypatch.chdir(tmp_path)
    exec(compile(python, "data-format.md", "exec"), {})
    for line in shell:
        assert shlex.split(line)[0] == "tensegrid"
        assert main(shlex.split(line)[1:]) == 0, capsys.readouterr()
    np.testing.assert_allclose(load_trajectory(tmp_path / "lab.nc")["nodes"].values[:, :, 2].min(), 0.06, atol=0.01)
