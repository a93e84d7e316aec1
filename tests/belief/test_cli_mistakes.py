"""Mistakes ``tensegrid identify`` once let through to a failed run: a prior box in the wrong unit, a prior
box that excludes the rods the markers measure, and a CSV given where a netCDF trajectory belongs. Each is
a one-line typed error that names the fix, raised before any simulation and leaving no --out (so no
journal); the command corrected as the message says then runs."""
from __future__ import annotations

import json
import os
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

import physics.trajectory_objective
from belief import IdentificationResult
from belief.presets import reserved_evaluations
from physics import FlopController, ParameterSpace, save_trajectory, simulate
from physics.checks import ROD_LENGTH_TOLERANCE, check_trajectory, require_rods_in_box
from physics.cli import main
from physics.errors import ParameterError, TrajectoryFormatError
from physics.importers import to_csv
from physics.prior_box import prior_box
from physics.trajectory import load_trajectory

# random search of 2 evaluations: the T6's D + 4 = 19 of the budget are kept for the assessment (_ran)
RUN = ["--preset", "random", "--budget", "21", "--no-progress", "--no-next"]


@pytest.fixture(scope="module")
def flop(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """0.3 s of the nominal SUPERball (rods 1.74 m) starting a flop, saved as netCDF."""
    path = tmp_path_factory.mktemp("data") / "flop.nc"
    return save_trajectory(simulate(controller=FlopController(heading=0.0), duration=0.3), path)


@pytest.fixture
def models(monkeypatch: pytest.MonkeyPatch) -> list[object]:
    """The T6 models the trajectory objective builds, one per simulation pass: empty means nothing ran."""
    built: list[object] = []
    real = physics.trajectory_objective.T6Model

    def spy(*args: object, **kwargs: object) -> object:
        built.append(args)
        return real(*args, **kwargs)

    monkeypatch.setattr(physics.trajectory_objective, "T6Model", spy)
    return built


def _refused(argv: list[str], folder: Path, capsys: pytest.CaptureFixture[str], built: list[object],
             *needles: str) -> str:
    """Run ``argv``: exit code 2, one error line on stderr containing ``needles``, no simulation, and
    nothing new in ``folder`` (no --out, no journal). Returns the line."""
    before = sorted(os.listdir(folder))
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip() and ": note: " not in line]
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert built == [], "a simulation ran before the mistake was refused"
    assert sorted(os.listdir(folder)) == before
    return lines[0]


def _ran(out: Path, built: list[object]) -> None:
    result = IdentificationResult.load(out / "result.nc")
    dim = result.marginals.sizes["parameter"]       # 15 on the T6, fewer when the model holds some at nominal
    assert result.n_evaluations == 21 - reserved_evaluations("random", dim)      # 2 for D = 15
    assert result.config["evaluations"]["total"] <= 21
    assert built, "the corrected run simulated nothing: the spy does not see the simulations"


def test_a_prior_box_in_millimetres_is_refused_naming_the_si_value(tmp_path, flop, models, capsys) -> None:
    out = tmp_path / "run"
    params = tmp_path / "box.json"
    params.write_text(json.dumps({"rod_length": {"nominal": 1740, "lower": 1600, "upper": 1900}}))
    slips = {"--nominal": ("rod_length=1658", "--nominal rod_length=1658 m is 950 times the box's range "
                           "1.57-1.91 m: the unit is m (did you give millimetres?); give --nominal rod_length=1.658."),
             "--bounds": ("rod_length=160:190", "(did you give centimetres?); give --bounds rod_length=1.6:1.9."),
             "--params": (str(params), f"--params {params}: rod_length nominal = 1740, lower = 1600, upper = 1900 m "
                          "is 920 times the box's range 1.57-1.91 m: the unit is m (did you give millimetres?); write "
                          "nominal = 1.74, lower = 1.6, upper = 1.9 in the file.")}
    for option, (value, says) in slips.items():
        _refused(["identify", str(flop), *RUN, option, value, "--out", str(out)], tmp_path, capsys, models, says)
        _refused(["diagnose", str(flop), option, value, "--out", str(out)], tmp_path, capsys, models,
                 "tensegrid diagnose: error:", says)
    far = prior_box(ParameterSpace.t6(), nominal=["stiffnessActive=20000"], bounds=["damping=0:5000"])
    assert (far["stiffnessActive"].nominal, far["damping"].upper) == (20000.0, 5000.0)    # no wrong unit explains it
    fixed = _refused(["identify", str(flop), *RUN, "--nominal", "rod_length=1658", "--out", str(out)],
                     tmp_path, capsys, models)
    corrected = re.search(r"give (--nominal \S+)\.$", fixed)
    assert corrected is not None
    assert main(["identify", str(flop), *RUN, *corrected.group(1).split(" ", 1), "--out", str(out)]) == 0
    _ran(out, models)


def test_a_box_that_excludes_the_measured_rods_is_refused_with_the_fix(tmp_path, flop, models, capsys) -> None:
    out = tmp_path / "run"
    line = _refused(["identify", str(flop), *RUN, "--nominal", "rod_length=1.5", "--out", str(out)], tmp_path,
                    capsys, models, f"tensegrid identify: {flop}: the rods measure 1.74 m (median distance of their "
                    "end markers), 90 mm outside the rod_length box [1.35, 1.65] m (tolerance 5 mm); give --bounds "
                    "rod_length=1.57:1.91 or --nominal rod_length=1.74.")
    _refused(["identify", str(flop), *RUN, "--bounds", "rod_length=1.75:1.9", "--out", str(out)], tmp_path, capsys,
             models, "10 mm outside the rod_length box [1.75, 1.9] m")
    fix = re.search(r"give (--bounds \S+) or", line)
    assert fix is not None
    assert main(["identify", str(flop), *RUN, *fix.group(1).split(" ", 1), "--out", str(out)]) == 0
    _ran(out, models)


def test_the_rod_length_tolerance_is_a_few_millimetres(flop) -> None:
    report = check_trajectory(load_trajectory(flop), source="flop.nc")
    assert report.rod_length == pytest.approx(1.74, abs=1e-6) and ROD_LENGTH_TOLERANCE == 0.005
    t6 = ParameterSpace.t6()
    for gap, refused in ((-0.004, False), (0.0, False), (0.004, False), (0.006, True), (0.1, True)):
        for bounds in ((1.74 + gap, 2.0), (1.5, 1.74 - gap)):
            space = t6.with_overrides(bounds={"rod_length": bounds})
            if refused:
                with pytest.raises(ParameterError, match=r"^flop\.nc: the rods measure 1\.74 m"):
                    require_rods_in_box([report], space)
            else:
                require_rods_in_box([report], space)


def test_a_csv_is_refused_with_the_convert_command_that_fixes_it(tmp_path, flop, models, capsys) -> None:
    csv = to_csv(load_trajectory(flop), tmp_path / "DATA.csv")
    out = tmp_path / "run"
    says = (f"{csv} is not a netCDF trajectory; convert it first: tensegrid convert {csv} {tmp_path / 'DATA.nc'} "
            "--units m|cm|mm (see docs/data-format.md).")
    line = _refused(["identify", str(csv), *RUN, "--out", str(out)], tmp_path, capsys, models,
                    f"tensegrid identify: {says}")
    assert "backend" not in line and "xarray" not in line
    _refused(["diagnose", str(csv), "--out", str(out)], tmp_path, capsys, models, says)
    assert main(["check", str(csv)]) == 2
    assert f"{csv}: error format: {says}" in capsys.readouterr().out.splitlines()
    with pytest.raises(TrajectoryFormatError, match="is not a netCDF trajectory"):
        load_trajectory(csv)
    command = shlex.split(line.split("convert it first: ", 1)[1].split(" (see", 1)[0].replace("m|cm|mm", "m"))
    assert command[:2] == ["tensegrid", "convert"] and main(command[1:]) == 0
    capsys.readouterr()
    converted = load_trajectory(tmp_path / "DATA.nc")
    assert np.allclose(converted["nodes"].values, load_trajectory(flop)["nodes"].values)
    assert main(["identify", str(tmp_path / "DATA.nc"), *RUN, "--out", str(out)]) == 0
    _ran(out, models)


def test_netcdf_files_of_both_formats_still_load(tmp_path, flop) -> None:
    """The netCDF signature test accepts netCDF-4 (HDF5) and classic files alike."""
    classic = tmp_path / "classic.nc"
    load_trajectory(flop).to_netcdf(classic, format="NETCDF3_64BIT")
    assert classic.read_bytes()[:3] == b"CDF" and flop.read_bytes()[1:4] == b"HDF"
    assert load_trajectory(classic).sizes == load_trajectory(flop).sizes
