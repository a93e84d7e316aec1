"""identify and diagnose on data with encoder readings put the actuator read from them in the model
(issue 68, item 2): reported, the motor parameters held as inert, carried to simulate --replay and
model.json; --actuator model keeps the motor model."""
from __future__ import annotations

import json

import pytest
import xarray as xr

from physics import FlopController, ParameterSpace, save_trajectory, simulate
from physics.cli import main
from physics.effects import MOTOR_PARAMETERS, MeasuredActuator, model_space

LAW = MeasuredActuator(delay=0.05, rate=0.3)


@pytest.fixture(scope="module")
def law_files(tmp_path_factory) -> list[str]:
    """Three flops of the library's robot driven 50 ms late at 0.3 m/s (an actuator the motor model is not)."""
    folder = tmp_path_factory.mktemp("law")
    theta = dict(zip(model_space((LAW,)).names, ParameterSpace.t6().nominal, strict=True))
    flops = [simulate(theta, controller=FlopController(heading=h), duration=1.5, effects=(LAW,), noise=2e-4, seed=k)
             for k, h in enumerate((0.0, 2.1, 4.2))]
    for ds in flops:
        ds.attrs.pop("effects", None)           # the recording does not say how its actuator works
    return [str(save_trajectory(ds.drop_vars("theta"), folder / f"{k}.nc")) for k, ds in enumerate(flops)]


def _identify(files: list[str], out, *extra: str) -> int:
    return main(["identify", *files, "--preset", "bo-gn", "--budget", "25", "--candidates", "256", "--out", str(out),
                 "--no-progress", "--no-next", *extra])


def test_identify_reads_the_actuator_holds_the_motor_and_replays_with_it(law_files, tmp_path, capsys) -> None:
    assert _identify(law_files, tmp_path / "run") == 0
    printed = capsys.readouterr().out
    assert "actuator read from the encoders: The motors follow their commands 50 ms late" in printed
    assert "the measured law is the model's actuator" in printed
    assert "inert (the measured actuator replaces the motor that read them): " + ", ".join(MOTOR_PARAMETERS) in printed
    summary = (tmp_path / "run" / "summary.txt").read_text()
    assert "the measured law is the model's actuator" in summary
    page = (tmp_path / "run" / "report.html").read_text(encoding="utf-8")
    assert "The actuator read from the encoders" in page and "50 ms late" in page
    from belief.result import IdentificationResult
    result = IdentificationResult.load(tmp_path / "run" / "result.nc")
    assert [e["effect"] for e in result.config["effects"]] == ["measured_actuator"]
    assert set(MOTOR_PARAMETERS) <= set(result.config["fixed"]) and result.best_theta.sizes["parameter"] == 10
    assert result.config["actuator"]["measured"] is True
    assert main(["simulate", "--from", str(tmp_path / "run" / "result.nc"), "--replay", law_files[0],
                 "--out", str(tmp_path / "sim")]) == 0
    assert "effects measured_actuator" in capsys.readouterr().out


def test_actuator_model_keeps_the_motor(law_files, tmp_path, capsys) -> None:
    assert _identify(law_files, tmp_path / "run", "--actuator", "model") == 0
    printed = capsys.readouterr().out
    assert "actuator read from the encoders" not in printed and "inert (" not in printed
    from belief.result import IdentificationResult
    result = IdentificationResult.load(tmp_path / "run" / "result.nc")
    assert result.config["effects"] == [] and result.best_theta.sizes["parameter"] == 15


def test_actuator_measured_without_readings_is_refused_before_anything_runs(law_files, tmp_path, capsys) -> None:
    bare = tmp_path / "bare.nc"
    save_trajectory(xr.load_dataset(law_files[0]).drop_vars("rest_length"), bare)
    assert _identify([str(bare)], tmp_path / "run", "--actuator", "measured") == 2
    assert "--actuator measured needs encoder readings" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_a_model_file_carries_the_measured_actuator(tmp_path) -> None:
    from physics.model_file import read_model_file, write_model_file
    path = tmp_path / "model.json"
    write_model_file(path, (LAW,))
    assert json.loads(path.read_text())["effects"][0]["effect"] == "measured_actuator"
    assert read_model_file(path) == (LAW,)


def test_diagnose_reads_the_actuator_first_and_searches_no_actuator_effect(law_files, tmp_path) -> None:
    """diagnose, shrunk to one cheap pass: the measured actuator is in the first model, the catalog's
    actuator delay is superseded, the report names it and the inert parameters, model.json carries it."""
    from criticism.diagnose import DiagnoseConfig, diagnose
    from criticism.report import diagnosis_text, write_report
    from criticism.search import CriticismConfig
    from physics.effects import ActuatorDelay, AirDrag
    from belief.least_squares import LeastSquaresConfig

    data = [xr.load_dataset(f) for f in law_files[:2]]
    d = diagnose(data, effects=[ActuatorDelay(), AirDrag()], n_workers=1, progress=False,
                 config=DiagnoseConfig(passes=1, budget=6, candidates=32, horizon=5, mismatch=None,
                                       measure_at_rest=False, wider_box=None, revisit=False,
                                       criticism=CriticismConfig(local=LeastSquaresConfig(evaluations=2))))
    assert d.actuator is not None and d.actuator.measured
    assert [e.name for e in d.first_model] == ["measured_actuator"]
    assert d.passes[0].effects == ("measured_actuator",)
    assert [c.name for c in d.passes[0].criticism.ranking] == ["air_drag"]
    text = diagnosis_text(d)
    assert text.startswith("actuator read from the encoders: The motors follow their commands 50 ms late")
    assert "inert under the measured actuator" in text and "motor_inertia" in text
    write_report(d, data, tmp_path)
    model = json.loads((tmp_path / "model.json").read_text())
    assert model["effects"][0]["effect"] == "measured_actuator"
    assert json.loads((tmp_path / "diagnosis.json").read_text())["actuator"]["measured"] is True
