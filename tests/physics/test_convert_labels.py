"""``tensegrid convert`` with marker labels: ``--labels``, the ``{label}``/``{AXIS}``/``{a}``/``{b}`` placeholders,
one-line errors for bad mappings and missing columns, and no output file when a check finds an error.

The CSVs are written here without physics.importers, as a motion-capture export would look: labelled
marker columns ``A1:X ... F2:Z`` (rod A joins A1 and A2), millimetres, y up, a jittered clock, dropped
frames, columns in no particular order and cable commands named by their two end markers in either order.
"""
from __future__ import annotations

import shlex
from pathlib import Path
from typing import get_args

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from physics import FlopController, simulate
from physics.cli import main
from physics.cli_convert import ConvertOptions, LengthUnit, TimeUnit, UpAxis
from physics.column_patterns import ColumnLayout
from physics.errors import ImportFormatError
from physics.geometry import CABLE_NODES
from physics.importers import LENGTH_UNITS, TIME_UNITS, UP_AXES, from_csv, to_csv
from physics.trajectory import load_trajectory, save_trajectory

LABELS = ["A1", "A2", "B1", "B2", "C1", "C2", "D1", "D2", "E1", "E2", "F1", "F2"]
DROPPED = [12, 30]
OPTIONS = ["--node-columns", "{label}:{AXIS}", "--control-columns", "motor_{a}_{b}", "--time-column", "Time (s)",
           "--units", "mm", "--up", "y"]


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, xr.Dataset]:
    """0.5 s of the nominal robot starting a flop at 100 Hz, saved as netCDF and read back."""
    path = save_trajectory(simulate(controller=FlopController(heading=0.0), duration=0.5, settle=1.0),
                           tmp_path_factory.mktemp("reference") / "made.nc")
    return path, load_trajectory(path)


def _mocap_csv(ds: xr.Dataset, path: Path, *, rename: dict[str, str] | None = None) -> Path:
    """The labelled export of ``ds``: mm, file axes (x, y, z) = world (x, z, -y) (y up, right-handed),
    timestamps off their 100 Hz ticks by up to ±0.5 ms (5 % of the interval), rows DROPPED left out,
    columns shuffled, and cable j named motor_<end a>_<end b> for even j, motor_<end b>_<end a> for odd j."""
    rng = np.random.default_rng(7)
    world = ds["nodes"].values * 1000.0
    file_xyz = np.stack([world[..., 0], world[..., 2], -world[..., 1]], axis=-1)
    columns = {"Frame": np.arange(ds.sizes["time"]),
               "Time (s)": ds["time"].values + rng.uniform(-5e-4, 5e-4, ds.sizes["time"])}
    for n, label in enumerate(LABELS):
        for a, axis in enumerate("XYZ"):
            columns[f"{label}:{axis}"] = file_xyz[:, n, a]
    for c, (a, b) in enumerate(CABLE_NODES):
        ends = (LABELS[a], LABELS[b]) if c % 2 == 0 else (LABELS[b], LABELS[a])
        columns["motor_{}_{}".format(*ends)] = ds["controls"].values[:, c] * 1000.0
    table = pd.DataFrame(columns).drop(index=DROPPED)
    order = rng.permutation(table.columns)
    table[order].rename(columns=rename or {}).to_csv(path, index=False)
    return path


def _convert(csv: Path, out: Path, *extra: str) -> int:
    return main(["convert", str(csv), str(out), *extra])


def test_a_labelled_mocap_csv_converts_to_the_netcdf_it_was_made_from(
        tmp_path: Path, reference: tuple[Path, xr.Dataset], capsys: pytest.CaptureFixture[str]) -> None:
    made, ref = reference
    csv = _mocap_csv(ref, tmp_path / "mocap.csv")
    out = tmp_path / "mocap.nc"
    assert _convert(csv, out, "--labels", ",".join(LABELS), *OPTIONS) == 0, capsys.readouterr()
    back = load_trajectory(out)
    kept = np.setdiff1d(np.arange(ref.sizes["time"]), DROPPED)
    np.testing.assert_allclose(np.diff(back["time"].values), 0.01, rtol=0, atol=1e-12)      # jitter snapped
    np.testing.assert_allclose(back["time"].values, ref["time"].values, rtol=0, atol=1e-4)   # to the fitted clock
    for var in ("nodes", "controls"):
        assert np.isnan(back[var].values[DROPPED]).all(), var
        np.testing.assert_allclose(back[var].values[kept], ref[var].values[kept], rtol=0, atol=1e-6, err_msg=var)
    assert back.attrs["csv_labels"] == ",".join(LABELS) and "made.nc" not in back.attrs["source"]
    assert "checks: 0 error(s)" in capsys.readouterr().out


BAD_MAPPINGS = [
    ("duplicate", ["--labels", ",".join(["A1", "A2", "A1", *LABELS[3:]])],
     "labels: duplicate label: 'A1' twice for nodes 0 and 2"),
    ("duplicate-case", ["--labels", ",".join([*LABELS[:11], "a1"])],
     "labels: duplicate label: 'A1' and 'a1', the same without case, for nodes 0 and 11"),
    ("count", ["--labels", ",".join(LABELS[:11])], "labels: 11 given (A1, A2, B1, B2, C1, C2, D1, D2, E1, E2, F1), "
                                                   "12 needed"),
    ("empty", ["--labels", ",".join(["A1", "", *LABELS[2:]])], "the label of node 1 is empty"),
    ("a-in-node-pattern", ["--labels", ",".join(LABELS), "--node-columns", "{label}:{a}"],
     "node_columns '{label}:{a}': the placeholder {a} is unknown in a node pattern; it may use {node}, {label}, "
     "{axis}, {AXIS}."),
    ("unknown", ["--labels", ",".join(LABELS), "--node-columns", "{label}:{foo}"],
     "the placeholder {foo} is unknown in a node pattern"),
    ("a-without-b", ["--labels", ",".join(LABELS), "--control-columns", "motor_{a}"],
     "control_columns 'motor_{a}' uses {a} without {b}"),
    ("no-axis", ["--labels", ",".join(LABELS), "--node-columns", "{label}"], "needs {axis} or {AXIS}"),
    ("same-names", ["--labels", ",".join(LABELS), "--rest-length-columns", "motor_{b}_{a}"],
     "would stand for both the control of c00_04 and the rest length of c00_04"),
]


@pytest.mark.parametrize("bad, message", [c[1:] for c in BAD_MAPPINGS], ids=[c[0] for c in BAD_MAPPINGS])
def test_a_bad_label_mapping_is_a_one_line_error_before_anything_is_read(
        tmp_path: Path, reference: tuple[Path, xr.Dataset], capsys: pytest.CaptureFixture[str], bad: list[str],
        message: str) -> None:
    """The bad options replace the good ones; the good command then converts."""
    csv = _mocap_csv(reference[1], tmp_path / "mocap.csv")
    out = tmp_path / "mocap.nc"
    good = dict(zip(OPTIONS[::2], OPTIONS[1::2], strict=True)) | {"--labels": ",".join(LABELS)}
    argv = [part for flag, value in (good | dict(zip(bad[::2], bad[1::2], strict=True))).items()
            for part in (flag, value)]
    for source in (csv, tmp_path / "absent.csv"):         # the same error when the CSV does not even exist
        assert _convert(source, out, *argv) == 2
        printed = capsys.readouterr()
        assert printed.out == "" and printed.err.count("\n") == 1, printed
        assert printed.err.startswith("tensegrid convert: error: ") and message in printed.err, printed.err
        assert not out.exists()
    assert _convert(csv, out, *[part for flag, value in good.items() for part in (flag, value)]) == 0
    assert out.exists()


def test_the_api_refuses_a_bad_layout_before_reading(tmp_path: Path) -> None:
    absent = tmp_path / "absent.csv"
    with pytest.raises(ImportFormatError, match="duplicate label"):
        from_csv(absent, labels=["A1", *LABELS[:11]])
    with pytest.raises(ImportFormatError, match="got the string"):
        from_csv(absent, labels=",".join(LABELS))
    with pytest.raises(ImportFormatError, match="would stand for both the time column and node 0 x"):
        ColumnLayout(time_column="NODE0_X")
    with pytest.raises(ImportFormatError, match="is not a pattern"):
        ColumnLayout(node_columns="{label:{axis}")
    with pytest.raises(ImportFormatError, match="cannot be filled in"):
        ColumnLayout(node_columns="{label:03d}{axis}", labels=tuple(LABELS))


def test_a_missing_column_names_the_nearest_match_and_the_columns_found(
        tmp_path: Path, reference: tuple[Path, xr.Dataset], capsys: pytest.CaptureFixture[str]) -> None:
    csv = _mocap_csv(reference[1], tmp_path / "mocap.csv", rename={"C2:Y": "C2.Y"})
    out = tmp_path / "mocap.nc"
    assert _convert(csv, out, "--labels", ",".join(LABELS), *OPTIONS) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and not out.exists()
    assert "node columns missing: C2:Y; nearest to 'C2:Y': 'C2.Y'; the file has 62 columns: " in err, err
    assert "and 54 more" in err                                           # 8 of the 62 shown
    whole = _mocap_csv(reference[1], tmp_path / "whole.csv")
    assert _convert(whole, out, *OPTIONS) == 2                            # --labels forgotten
    err = capsys.readouterr().err
    assert "no node column (expected e.g. '0:X')" in err and "without labels, {label}, {a} and {b} are node" in err
    assert _convert(whole, out, "--labels", ",".join(LABELS), *OPTIONS[:4], *OPTIONS[6:]) == 2   # Time (s) vs time
    assert "nearest to 'time': 'Time (s)'" in capsys.readouterr().err


def test_a_check_error_writes_nothing_and_names_the_command_that_converts(
        tmp_path: Path, reference: tuple[Path, xr.Dataset], capsys: pytest.CaptureFixture[str]) -> None:
    csv = _mocap_csv(reference[1], tmp_path / "mocap.csv")
    out = tmp_path / "mocap.nc"
    no_up = ["--labels", ",".join(LABELS), *OPTIONS[:-2]]                  # the file's y up read as z up
    assert _convert(csv, out, *no_up) == 2
    printed = capsys.readouterr()
    assert "error up-axis" in printed.out and "hint: the CSV's up axis looks like y, not z" in printed.out
    assert not out.exists() and printed.err.count("\n") == 1
    command = printed.err.split("convert again with: ", 1)[1].strip()
    assert command.startswith(f"tensegrid convert {csv} {out} --units mm --up y ")
    argv = shlex.split(command)
    assert argv[:2] == ["tensegrid", "convert"] and main(argv[1:]) == 0
    np.testing.assert_allclose(load_trajectory(out)["nodes"].values[5], reference[1]["nodes"].values[5], atol=1e-6)
    out.write_text("precious")                                             # --force keeps a file on an error
    assert _convert(csv, out, *no_up, "--force") == 2 and out.read_text() == "precious"
    capsys.readouterr()
    assert _convert(csv, tmp_path / "anyway.nc", *no_up, "--skip-checks") == 0
    assert "(written anyway: --skip-checks)" in capsys.readouterr().out and (tmp_path / "anyway.nc").exists()


def test_without_labels_a_and_b_are_node_numbers_and_to_csv_round_trips(
        tmp_path: Path, reference: tuple[Path, xr.Dataset]) -> None:
    ref = reference[1]
    path = to_csv(ref, tmp_path / "numbers.csv", control_columns="m_{a}_{b}", node_columns="n{label}{AXIS}")
    header = pd.read_csv(path, nrows=0).columns
    assert {"m_0_4", "m_7_9", "n0X", "n11Z"} <= set(header)
    back = from_csv(path, control_columns="m_{b}_{a}", node_columns="N{node}{axis}")      # either order, any case
    np.testing.assert_allclose(back["controls"].values, ref["controls"].values, atol=1e-12)
    path = to_csv(ref, tmp_path / "labels.csv", control_columns="{a}-{b}", labels=LABELS, units="cm", up="-x")
    back = from_csv(path, control_columns="{a}-{b}", labels=LABELS, units="cm", up="-x")
    np.testing.assert_allclose(back["nodes"].values, ref["nodes"].values, atol=1e-9)
    table = pd.read_csv(path)
    table.assign(**{"C1-A1": table["A1-C1"]}).to_csv(tmp_path / "both.csv", index=False)
    with pytest.raises(ImportFormatError, match="'A1-C1' and 'C1-A1' name the same cable"):
        from_csv(tmp_path / "both.csv", control_columns="{a}-{b}", labels=LABELS, units="cm", up="-x")


def test_the_option_types_list_the_importer_choices() -> None:
    assert get_args(LengthUnit) == tuple(LENGTH_UNITS) and get_args(TimeUnit) == tuple(TIME_UNITS)
    assert get_args(UpAxis) == UP_AXES
    with pytest.raises(ImportFormatError, match="--units must be one of m, cm, mm"):
        ConvertOptions(csv="a.csv", out="a.nc", units="inch")  # type: ignore[arg-type]
    command = ConvertOptions(csv="my data.csv", out="a.nc", time_column="Time (s)", labels="A,B", force=True).command()
    assert shlex.split(command) == ["tensegrid", "convert", "my data.csv", "a.nc", "--time-column", "Time (s)",
                                    "--labels", "A,B", "--force"]
