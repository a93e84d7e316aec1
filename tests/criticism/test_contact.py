"""The contact read from the flops as parts of the model (criticism.contact) and in diagnose:
flat ends join the model before the stage, an evident marker offset before identifying."""
from __future__ import annotations

import json

import pytest
import xarray as xr

from belief.least_squares import LeastSquaresConfig
from criticism import CriticismConfig, DiagnoseConfig, diagnose, diagnosis_record, diagnosis_text, write_report
from criticism.contact import read_contact
from physics import FlopController, simulate
from physics.effects import ActuatorDelay, CylinderCaps, SensorBias, effect_from_config, model_space
from physics.errors import ParameterError

#: Screening alone, on a short re-tuning: these tests are about the contact read, not the fits.
SCREEN_ONLY = CriticismConfig(grid=3, refine=3, joint=0, local=LeastSquaresConfig(evaluations=3))
OFFSET = 0.012


def _flops(effects: list, values: dict[str, float]) -> list[xr.Dataset]:
    space = model_space(effects)
    theta = space.as_array({**space.as_dict(None), **values})
    return [simulate(theta, controller=FlopController(h), duration=1.0, effects=effects, noise=2e-4, seed=k)
            for k, h in enumerate((0.0, 2.1))]


@pytest.fixture(scope="module")
def flat_ends() -> list[xr.Dataset]:
    """Two 1-s flops of the T6 touching the floor with its end cylinders, observed 12 mm high."""
    return _flops([CylinderCaps(), SensorBias()], {"sensor_bias_z": OFFSET})


def test_flat_ends_bring_the_caps_and_an_evident_offset_spheres_bring_nothing(flat_ends) -> None:
    reading = read_contact(flat_ends)
    assert [e.name for e in reading.components] == ["cylinder_caps"], reading.text()
    bias = reading.bias
    assert bias is not None and bias.evident and bias.from_flops
    (p,) = bias.parameters()
    assert p.lower < OFFSET < p.upper and p.upper - p.lower <= 0.0101 and "read from the flops" in p.description
    assert effect_from_config(bias.config()).evident                       # the record keeps where it was read
    spheres = read_contact(_flops([], {}))
    assert spheres.components == () and spheres.bias is None and spheres.law is not None
    assert spheres.law.shape == "sphere"
    short = read_contact([simulate(None, controller=FlopController(0.0), duration=0.05, noise=2e-4, seed=0)])
    assert short.law is None and short.components == () and "too few contact samples" in short.text()
    assert not SensorBias(measured=OFFSET).evident                          # at rest it is one number with r
    assert not SensorBias(measured=0.003, width=0.002, from_flops=True).evident   # under EVIDENT_OFFSET
    assert not SensorBias(measured=0.008, width=0.01, from_flops=True).evident    # its box holds zero
    with pytest.raises(ParameterError, match="needs the measured offset"):
        SensorBias(from_flops=True)


@pytest.mark.slow
def test_diagnose_reads_the_contact_first_and_writes_it_to_the_model(tmp_path, flat_ends) -> None:
    config = DiagnoseConfig(budget=6, candidates=64, passes=1, horizon=10, mismatch=None, read_contact=True,
                            criticism=SCREEN_ONLY)
    d = diagnose(flat_ends, held_out=[1], effects=[SensorBias(), ActuatorDelay()], config=config, n_workers=0,
                 progress=False)
    assert d.contact is not None and [e.name for e in d.first_model] == ["cylinder_caps", "sensor_bias"]
    assert [e.name for e in d.measured] == ["sensor_bias"] and d.found[0] == "sensor_bias"
    assert d.passes[0].effects == ("cylinder_caps", "sensor_bias")
    assert [c.name for c in d.passes[0].criticism.ranking] == ["actuator_delay"]
    text = diagnosis_text(d)
    assert "contact law: end caps flat" in text and "read from the flops: sensor_bias (sensor_bias_z=" in text
    assert diagnosis_record(d)["contact"]["components"] == [{"effect": "cylinder_caps"}]
    write_report(d, flat_ends, tmp_path / "diag")
    record = json.loads((tmp_path / "diag" / "model.json").read_text())
    assert [e["effect"] for e in record["effects"][:2]] == ["cylinder_caps", "sensor_bias"]
    unread = diagnose(flat_ends, held_out=[1], effects=[ActuatorDelay()], n_workers=0, progress=False,
                      config=DiagnoseConfig(budget=6, candidates=64, passes=1, horizon=10, mismatch=None,
                                            criticism=SCREEN_ONLY))
    assert unread.contact is None and unread.measured == () and "contact law" not in diagnosis_text(unread)
