"""``tensegrid identify --measured NAME=VALUE+-SD --fix NAME=VALUE``: bad values are one-line errors raised
before the data are read or anything runs, leaving no --out; good ones are recorded in result.nc and
summary.txt, and the fixed parameters leave the search."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from belief import IdentificationResult
from physics.cli import main

# with mu fixed the search is 1-D: bo searches 6 of the 11 and keeps D + 4 = 5 for its assessment
TOY = ["--toy", "push", "--preset", "bo", "--no-progress", "--budget", "11"]


def _error(capsys: pytest.CaptureFixture[str], *needles: str) -> str:
    """The one error line on stderr, checked to contain ``needles``."""
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip() and ": note: " not in line]
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


BAD = {
    "unknown name": (["--measured", "rod_mas=3.0+-0.1"],
                     "measured rod_mas: unknown quantity; the known ones are rod_mass, total_mass, rod_inertia, "
                     "density"),
    "grams": (["--measured", "rod_mass=3000+-10"],
              "measured rod_mass=3000 kg is 1000 times the box's range 1.52-5.23 kg: the unit is kg (did you give "
              "grams?)"),
    "outside the box": (["--measured", "rod_length=2.5±0.01"],
                        "lies outside the range 1.566-1.914 m that the prior box allows; widen the box with "
                        "--bounds rod_length=LO:HI or --nominal rod_length=VALUE"),
    "no uncertainty": (["--measured", "rod_mass=3.0"], "is not of the form NAME=VALUE+-SD"),
    "impossible": (["--measured", "rod_inertia=-1+-0.1"], "is impossible: it must be > 0 kg*m^2"),
    "fixed and measured": (["--measured", "rod_length=1.7+-0.01", "--fix", "rod_length=1.7"],
                           "rod_length is both fixed and measured"),
    "fixed twice": (["--fix", "damping=200", "--fix", "damping=190"], "fixed damping is given twice"),
    "fixed derived": (["--fix", "rod_mass=3.0"], "only a parameter can be fixed"),
    "fixed millimetres": (["--fix", "rod_length=1740"], "(did you give millimetres?)"),
}


@pytest.mark.parametrize("name", list(BAD))
def test_each_bad_value_is_a_one_line_error_before_the_data_are_read(name: str, tmp_path: Path, capsys) -> None:
    options, says = BAD[name]
    out = tmp_path / "run"
    never_read = str(tmp_path / "not-there.nc")      # the check comes first: this file is never opened
    assert main(["identify", never_read, *options, "--out", str(out), "--no-progress"]) == 2
    line = _error(capsys, says)
    assert line.startswith("tensegrid identify: ")
    assert not out.exists() and os.listdir(tmp_path) == []


def test_the_box_options_apply_before_the_check(tmp_path: Path, capsys) -> None:
    """--bounds widens what --measured may say: the same value then passes and the next step (reading the
    data) is the one that stops."""
    out = tmp_path / "run"
    assert main(["identify", str(tmp_path / "not-there.nc"), "--bounds", "rod_length=1.5:2.6", "--measured",
                 "rod_length=2.5+-0.01", "--out", str(out), "--no-progress"]) == 2
    line = _error(capsys)
    assert "rod_length" not in line and "not-there.nc" in line
    assert not out.exists()


def test_measured_and_fixed_values_are_recorded_and_the_fixed_leave_the_search(tmp_path: Path, capsys) -> None:
    out = tmp_path / "run"
    assert main(["identify", *TOY, "--measured", "m = 1.0 ± 0.1", "--fix", "mu=0.4", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "note: --measured values enter the posterior of the local stage (presets '*-local'" in captured.err
    assert "Measured by the user:" in captured.out
    result = IdentificationResult.load(out / "result.nc")
    assert result.config["measurements"] == [{"name": "m", "value": 1.0, "sd": 0.1, "unit": "kg"}]
    assert result.config["fixed"] == {"mu": 0.4}
    assert set(result.config["prior_box"]) == {"m", "mu"}                 # the whole box, the fixed one too
    assert list(result.history["parameter"].values) == ["m"]               # only m was searched
    assert result.config["evaluations"]["search"] == 11 - 5 and result.config["evaluations"]["total"] <= 11
    summary = (out / "summary.txt").read_text().splitlines()
    start = summary.index("Measured by the user:")
    assert summary[start:] == ["Measured by the user:", "  m = 1 ± 0.1 kg  (mass of the pushed point)",
                               "Fixed by the user (not identified):", "  mu = 0.4"]
