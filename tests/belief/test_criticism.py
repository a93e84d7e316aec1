"""Criticism and the closed loop on data with an undeclared effect (small versions of
benchmarks/effects.py, which prints the statistics over seeds)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from belief.criticism import CriticismConfig, criticize
from belief.diagnose import DiagnoseConfig, diagnose, split_masks
from belief.diagnose_report import write_report
from belief.errors import BeliefError
from belief.residuals import phases, residual_dataset, residual_summary
from physics import FlopController, HoldController, TrajectoryError, simulate
from physics.effects import ActuatorDelay, EncoderOffset, SensorBias, catalog, model_space

pytestmark = pytest.mark.slow


def _flops(effects=(), values=None, headings=(0.0, 2.1), noise=0.0002, duration=1.2, nan=0):
    space = model_space(effects)
    theta = space.as_array({**space.as_dict(None), **(values or {})}, check_bounds=False)
    data = [simulate(theta, controller=FlopController(h), duration=duration, effects=effects, noise=noise, seed=k)
            for k, h in enumerate(headings)]
    if nan:
        data[0]["nodes"][40:40 + nan] = np.nan
    return data, theta


def test_phases_follow_commands_and_contacts():
    rest = simulate(controller=HoldController(), duration=0.5)
    assert set(phases(rest)) == {"rest"}
    flop, _ = _flops(headings=(0.0,), noise=0.0)
    label = phases(flop[0])
    t = flop[0]["time"].values
    assert label[t < 0.19].tolist() == ["rest"] * int((t < 0.19).sum())      # the flop starts at 0.2 s
    assert "actuating" in label[(t > 0.2) & (t < 1.0)] and "contact" in label


def test_residuals_skip_nan_samples_and_say_how_many():
    data, theta = _flops(headings=(0.0,), nan=5, duration=1.0)
    objective = TrajectoryError(data, horizon=1, loss="squared", n_workers=0)
    res = residual_dataset(objective, theta)
    assert np.isfinite(res["residual"].values).all()
    summary = residual_summary(res)
    assert summary["skipped"] == [5 + 1]              # 5 missing samples, and the one after them cannot be predicted
    assert sum(v["share"] for v in summary["phases"].values()) == pytest.approx(1.0)


def test_criticism_finds_a_sensor_bias_and_its_size():
    effects = [SensorBias()]
    data, theta = _flops(effects, {"sensor_bias_z": 0.02})
    objective = TrajectoryError(data, horizon=25, loss="squared", n_workers=0)
    fit, held = split_masks(objective.segments, [1])
    crit = criticize(objective, theta[:15], fit=fit, held=held, effects=catalog(), progress=False)
    assert crit.verdict == "found" and crit.found.name == "sensor_bias"
    assert crit.found.values["sensor_bias_z"] == pytest.approx(0.02, abs=0.004)
    assert crit.found.explained > 0.5 and crit.ranking[0] is crit.found


def test_criticism_claims_nothing_on_data_the_model_explains():
    data, theta = _flops()
    objective = TrajectoryError(data, horizon=25, loss="squared", n_workers=0)
    fit, held = split_masks(objective.segments, [1])
    crit = criticize(objective, theta, fit=fit, held=held, effects=catalog(), progress=False)
    assert crit.verdict == "unexplained" and crit.found is None


def test_criticism_refuses_bad_masks_and_norm_loss():
    data, theta = _flops(headings=(0.0,), duration=0.5)
    objective = TrajectoryError(data, horizon=5, loss="squared", n_workers=0)
    S = len(objective.segments)
    with pytest.raises(BeliefError, match="disjoint"):
        criticize(objective, theta, fit=np.ones(S, bool), held=np.ones(S, bool), effects=catalog())
    norm = TrajectoryError(data, horizon=5, loss="norm", n_workers=0)
    fit, held = split_masks(norm.segments, [])
    with pytest.raises(BeliefError, match="sum-of-squares"):
        criticize(norm, theta, fit=fit, held=held, effects=catalog())


def test_the_loop_finds_an_undeclared_delay_and_halves_the_held_out_error(tmp_path):
    data, _ = _flops([ActuatorDelay()], {"actuator_delay": 0.08}, headings=(0.0, 2.1, 4.2), duration=1.5)
    d = diagnose(data, held_out=[2], config=DiagnoseConfig(budget=24, passes=1, candidates=512),
                 journal_dir=tmp_path, n_workers=0, progress=False)
    step = d.passes[0]
    assert step.criticism.ranking[0].name == "actuator_delay"
    assert d.found == ["actuator_delay"] and step.reduction >= 0.5
    paths = write_report(d, data, tmp_path)
    assert {p.name for p in paths} >= {"report.txt", "diagnosis.json", "residual_time.png", "signature.png"}
    record = json.loads((tmp_path / "diagnosis.json").read_text())
    assert record["passes"][0]["added"] == "actuator_delay"


def test_an_effect_outside_the_catalog_is_not_attributed_with_confidence():
    data, theta = _flops([EncoderOffset()], {"encoder_offset": 0.05})
    objective = TrajectoryError(data, horizon=25, loss="squared", n_workers=0)
    fit, held = split_masks(objective.segments, [1])
    crit = criticize(objective, theta[:15], fit=fit, held=held, effects=catalog(), progress=False,
                     config=CriticismConfig())
    assert crit.verdict == "unexplained", crit.table()
