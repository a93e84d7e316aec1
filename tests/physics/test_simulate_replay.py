"""``tensegrid simulate --from RESULT.nc --model MODEL.json --replay DATA.nc``: the identified robot
replayed against its recording, and the mistakes refused before anything is simulated.

The recordings are flops of the library's own engine at a known θ*, so the replay at θ* must
reproduce them to the noise level, and the replay at another θ must not.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from physics import FlopController, ParameterSpace, load_trajectory, save_trajectory, simulate
from physics.cli import main
from physics.effects import EFFECT_TYPES
from physics.model_file import write_model_file
from physics.replay import replay
from physics.tensegrity import T6Model

THETA_STAR = {"damping": 185.0, "pretension": 158.0, "rod_length": 1.72, "stiffnessActive": 830.0}


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with a 1 s flop at θ* (noise-free, velocities recorded) and the same with 1 mm noise."""
    folder = tmp_path_factory.mktemp("recordings")
    save_trajectory(simulate(THETA_STAR, controller=FlopController(heading=0.5), duration=1.0),
                    folder / "exact.nc")
    save_trajectory(simulate(THETA_STAR, controller=FlopController(heading=0.5), duration=1.0, noise=0.001,
                             seed=4), folder / "noisy.nc")
    return folder


def write_result(path: Path, values: dict[str, float], *, fixed: dict[str, float] | None = None,
                 effects: list[dict] | None = None, fmt: str = "tensegrid.identification/2") -> Path:
    """A result file as belief.result.IdentificationResult.save writes its root group."""
    root = xr.Dataset({"best_theta": ("parameter", np.array(list(values.values()), float))},
                      coords={"parameter": list(values)},
                      attrs={"format": fmt, "best_error": 0.0,
                             "config": json.dumps({"fixed": fixed or {}, "effects": effects or []})})
    root.to_netcdf(path, engine="netcdf4")
    return path


def star_result(path: Path) -> Path:
    """A result whose best θ is θ* (every T6 parameter named, as identify writes it)."""
    space = ParameterSpace.t6()
    nominal = dict(zip(space.names, space.nominal.tolist(), strict=True))
    return write_result(path, {**nominal, **THETA_STAR})


def run(*argv: str | Path) -> int:
    return main(["simulate", *map(str, argv)])


def replayed(out: Path) -> dict:
    return json.loads((out / "replay.json").read_text())


def test_the_best_theta_replays_the_noise_free_recording(data: Path, tmp_path: Path, capsys) -> None:
    result = star_result(tmp_path / "result.nc")
    assert run("--from", result, "--replay", data / "exact.nc", "--out", tmp_path / "star") == 0
    printed = capsys.readouterr().out
    assert "open-loop error (RMS node distance): 0.3 s" in printed
    record = replayed(tmp_path / "star")
    errors = record["open_loop_error_m"]
    assert set(errors) == {"0.3", "0.5", "1"}
    assert errors["0.3"] < 1e-4 and errors["0.5"] < 1e-4 and errors["1"] < 1e-4, errors
    assert record["initial_velocities"] == "recorded"
    assert {k: record["theta"][k] for k in THETA_STAR} == THETA_STAR
    rollout = load_trajectory(tmp_path / "star" / "trajectory.nc")
    recording = load_trajectory(data / "exact.nc")
    assert np.array_equal(rollout["time"].values, recording["time"].values)
    assert float(rollout["theta"].sel(parameter="rod_length")) == 1.72
    assert (tmp_path / "star" / "replay.png").stat().st_size > 10_000

    # the nominal robot (no --from) is told apart by the same numbers
    assert run("--replay", data / "exact.nc", "--out", tmp_path / "nominal") == 0
    assert replayed(tmp_path / "nominal")["open_loop_error_m"]["0.5"] > 100 * errors["0.5"] + 1e-3


def test_fixed_values_and_theta_overrides_enter_the_model(data: Path, tmp_path: Path) -> None:
    free = {k: v for k, v in THETA_STAR.items() if k != "rod_length"}
    result = write_result(tmp_path / "result.nc", free, fixed={"rod_length": 1.72})
    assert run("--from", result, "--replay", data / "exact.nc", "--theta", "damping=150",
               "--out", tmp_path / "out") == 0
    record = replayed(tmp_path / "out")
    assert record["theta"]["rod_length"] == 1.72 and record["theta"]["damping"] == 150.0
    assert record["theta"]["pretension"] == 158.0
    assert record["theta_from"] == [f"--from {result}", "--theta"]
    assert record["open_loop_error_m"]["0.5"] > 1e-3        # damping 150 is not θ*'s 185


def test_a_noisy_recording_is_reproduced_to_its_noise_level(data: Path, tmp_path: Path) -> None:
    result = star_result(tmp_path / "result.nc")
    assert run("--from", result, "--replay", data / "noisy.nc", "--out", tmp_path / "out") == 0
    record = replayed(tmp_path / "out")
    assert record["initial_velocities"] == "estimated"
    # 1 mm per coordinate is √3 mm of RMS node distance on its own
    assert record["open_loop_error_m"]["0.3"] < 0.005, record["open_loop_error_m"]


def test_the_model_file_adds_its_effects_and_theta(tmp_path: Path) -> None:
    delayed = {**THETA_STAR, "actuator_delay": 0.06}
    effects = [EFFECT_TYPES["actuator_delay"]()]
    save_trajectory(simulate(delayed, controller=FlopController(heading=0.0), duration=0.8, effects=effects),
                    tmp_path / "delayed.nc")
    write_model_file(tmp_path / "model.json", effects, delayed)
    assert run("--model", tmp_path / "model.json", "--replay", tmp_path / "delayed.nc", "--out", tmp_path / "m") == 0
    record = replayed(tmp_path / "m")
    assert record["effects"] == [{"effect": "actuator_delay"}] and record["theta"]["actuator_delay"] == 0.06
    assert record["open_loop_error_m"]["0.5"] < 1e-4
    result = star_result(tmp_path / "result.nc")        # θ* without the delay
    assert run("--from", result, "--replay", tmp_path / "delayed.nc", "--out", tmp_path / "r") == 0
    assert replayed(tmp_path / "r")["open_loop_error_m"]["0.5"] > 1e-3


def test_the_replay_api_reports_past_its_end_as_nan(data: Path) -> None:
    run_ = replay(load_trajectory(data / "exact.nc"), THETA_STAR, duration=0.4)
    errors = run_.errors(at=(0.3, 1.0))
    assert errors[0.3] < 1e-4 and np.isnan(errors[1.0])
    assert run_.rollout.sizes["time"] == 41 and run_.start == 0


def test_a_replay_can_start_mid_flop(data: Path) -> None:
    """From 0.25 s on the motors are spooling: their speed comes from the readings, not zero."""
    mid = load_trajectory(data / "exact.nc").isel(time=slice(25, None))
    run_ = replay(mid, THETA_STAR)
    assert run_.rollout["time"].values[0] == pytest.approx(0.25)
    assert run_.errors()[0.3] < 2e-3, run_.errors()


@pytest.fixture
def no_simulation(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if anything builds a model: the mistakes must be refused before that."""
    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("a model was built before the input was refused")
    monkeypatch.setattr(T6Model, "__init__", refuse)


def _relabelled(recording: xr.Dataset, order: list[int]) -> xr.Dataset:
    return recording.isel(node=order).assign_coords(node=range(len(order)))


def test_mistakes_are_one_line_errors_before_any_simulation(data: Path, tmp_path: Path, capsys,
                                                            no_simulation: None) -> None:
    star = star_result(tmp_path / "result.nc")
    (tmp_path / "notes.txt").write_text("best theta: see the report\n")
    recording = load_trajectory(data / "exact.nc")
    recording.isel(node=slice(0, 11)).to_netcdf(tmp_path / "eleven.nc")
    swapped = [0, 2, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11]             # an end of rod 0 and one of rod 1 exchanged
    _relabelled(recording, swapped).to_netcdf(tmp_path / "swapped.nc")
    strange = write_result(tmp_path / "strange.nc", {"densty": 300.0})
    delayed = write_result(tmp_path / "delayed.nc", {"actuator_delay": 0.05},
                           effects=[{"effect": "actuator_delay"}])
    write_model_file(tmp_path / "model.json", [EFFECT_TYPES["air_drag"]()])
    cases = {
        ("--from", data / "exact.nc", "--replay", data / "exact.nc"): "is not an identification result (it is a "
                                                                       "trajectory",
        ("--from", tmp_path / "notes.txt"): "is not a netCDF file",
        ("--from", tmp_path / "absent.nc"): "no result file at",
        ("--from", write_result(tmp_path / "belief.nc", THETA_STAR, fmt="tensegrid.belief/1")): "its format is "
                                                                                               "'tensegrid.belief/1'",
        ("--from", strange): "parameter(s) ['densty'] are not in the simulated model",
        ("--from", delayed, "--model", tmp_path / "model.json"): "['actuator_delay'] are not in the simulated model",
        ("--from", star, "--theta", "densty=300"): "--theta: Unknown parameter name(s) ['densty']",
        ("--from", star, "--replay", tmp_path / "eleven.nc"): "'node' must have 12 entries",
        ("--from", star, "--replay", tmp_path / "swapped.nc"): "nodes do not match the model: rod 0",
        ("--replay", data / "exact.nc", "--theta", "rod_length=1.5"): "nodes do not match the model",
        ("--replay", data / "exact.nc", "--flops", "2", "--noise", "0.001"): "--flops, --noise belong to the flop run",
    }
    for argv, message in cases.items():
        out = tmp_path / "never"
        assert run(*argv, "--out", out / "deeper") == 2, argv
        captured = capsys.readouterr()
        lines = captured.err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("tensegrid simulate: error: "), captured.err
        assert message in lines[0], (argv, lines[0])
        assert not captured.out and not out.exists(), argv


def test_a_result_of_a_real_identification_replays(data: Path, tmp_path: Path) -> None:
    """``tensegrid identify`` (2 evaluations of random search, the T6's D + 4 = 19 of the budget kept
    for the assessment) writes the result.nc that simulate --from reads."""
    short = tmp_path / "short.nc"
    save_trajectory(load_trajectory(data / "exact.nc").isel(time=slice(0, 41)), short)
    done = subprocess.run([sys.executable, "-m", "physics.cli", "identify", str(short), "--preset", "random",
                           "--budget", "21", "--no-progress", "--no-next", "--out", str(tmp_path / "id")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    with xr.open_dataset(tmp_path / "id" / "result.nc", engine="netcdf4") as root:
        best = {str(k): float(v) for k, v in zip(root["parameter"].values, root["best_theta"].values, strict=True)}
    assert run("--from", tmp_path / "id" / "result.nc", "--replay", short, "--out", tmp_path / "out") == 0
    record = replayed(tmp_path / "out")
    assert record["theta"] == best
    assert np.isfinite(record["open_loop_error_m"]["0.3"]) and record["open_loop_error_m"]["1"] is None
