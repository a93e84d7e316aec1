"""The actuator read from the encoders (physics.actuator_readings): laws recovered from synthetic
readings made by an independent 1 ms actuator (benchmarks/actuator_readings.py), findings for
readings no law explains, gaps and jitter, and the library's own motor."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from actuator_readings import ACTUATED, Actuator, as_dataset, encoder_readings, flop_commands

from physics.actuator_fitting import ActuatorRecord
from physics.actuator_laws import ActuatorLaw, LawForm
from physics.actuator_readings import ActuatorConfig, ActuatorReadingsError, identify_actuator
from physics.errors import ParameterError
from physics.geometry import CABLE_NAMES

RATE = 100.0


def _fit(actuator: Actuator, seed: int, **config: float):
    rng = np.random.default_rng(seed)
    commands = flop_commands(rng)
    return identify_actuator([as_dataset(commands, encoder_readings(commands, actuator, rng))],
                             ActuatorConfig(**config))


def test_the_law_predicts_what_a_one_millisecond_actuator_does():
    """Two parts per interval make a fractional delay exact on a rate-limited ramp (no noise)."""
    rng = np.random.default_rng(0)
    commands = flop_commands(rng)
    truth = encoder_readings(commands, Actuator(delay=0.025, rate=1.4, noise=0.0), rng)
    law = ActuatorLaw(form=LawForm(delay=True, rate_limit=True), delay=0.025, rate=1.4)
    assert np.max(np.abs(law.predict(commands, 1 / RATE) - truth)) < 1e-9
    late = ActuatorLaw(form=LawForm(delay=True, rate_limit=True), delay=0.03, rate=1.4)
    assert np.max(np.abs(late.predict(commands, 1 / RATE) - truth)) > 1e-3


def test_a_50_ms_delay_and_the_rate_limit_are_read_back():
    fit = _fit(Actuator(delay=0.05, rate=1.4), seed=1)
    assert fit.identified and fit.delay_claimed
    assert abs(fit.delay.value - 0.05) <= 1 / RATE
    assert abs(fit.rate.value / 1.4 - 1) < 0.05
    assert fit.delay.low <= 0.05 <= fit.delay.high + 0.5 / RATE
    assert fit.describe().startswith("The motors follow their commands 50 ms late")
    assert "at up to 1.4 m/s" in fit.describe()


def test_a_fractional_delay_is_read_within_half_a_sample():
    fit = _fit(Actuator(delay=0.025, rate=1.4), seed=2)
    assert fit.delay_claimed
    assert abs(fit.delay.value - 0.025) <= 0.5 / RATE


def test_nominal_readings_claim_no_delay():
    fit = _fit(Actuator(rate=1.4), seed=3)
    assert fit.identified and not fit.delay_claimed
    assert fit.law.delay == 0.0 and "no delay" in fit.describe()
    assert abs(fit.rate.value / 1.4 - 1) < 0.05


def test_a_lag_is_told_from_a_delay():
    fit = _fit(Actuator(time_constant=0.03, rate=1.4), seed=4)
    assert fit.law.form.lag and not fit.delay_claimed
    assert abs(fit.time_constant.value / 0.03 - 1) < 0.1
    delayed = _fit(Actuator(delay=0.03, rate=1.4), seed=4)
    assert delayed.delay_claimed and not delayed.law.form.lag


def test_one_mis_zeroed_cable_is_found_with_its_offset():
    cable = ACTUATED[2]
    fit = _fit(Actuator(delay=0.05, rate=1.4, offset=0.015, offset_cable=cable), seed=5)
    assert fit.offset_cables == (cable,)
    assert abs(fit.offsets[cable] - 0.015) < 1e-3
    assert f"Cable {CABLE_NAMES[cable]} reads +15" in fit.describe()
    assert any(f.code == "actuator_offset_cable" for f in fit.findings)


def test_the_tension_limit_is_read_from_readings_and_cable_lengths():
    """Shortened cables stop at ℓ - s; the slack s = maxTens / k is recovered, maxTens given k."""
    rng = np.random.default_rng(6)
    commands = flop_commands(rng)
    t = np.arange(commands.shape[0]) / RATE
    lengths = commands[0] + 0.05 + 0.01 * np.sin(2 * np.pi * 0.7 * t)[:, None]
    readings = encoder_readings(commands, Actuator(rate=1.4, slack=0.1), rng, lengths=lengths)
    compared = np.ones(commands.shape, bool)
    record = ActuatorRecord(commands, readings, compared, lengths, 1 / RATE, "tension")
    fit = identify_actuator([record], ActuatorConfig(stiffness=800.0))
    assert fit.law.form.tension_limit
    assert abs(fit.tension_slack.value / 0.1 - 1) < 0.05
    assert abs(fit.max_tension.value / 80.0 - 1) < 0.05
    assert "never stretching a cable more than 100 mm (maxTens 80 N)" in fit.describe()


def test_readings_that_follow_no_command_get_a_finding_not_a_fit():
    rng = np.random.default_rng(7)
    commands = flop_commands(rng)
    for noise in (0.02, 3e-4):       # noise around the mean command; a reading that stays put
        readings = commands.mean(axis=0) + rng.normal(0.0, noise, commands.shape)
        fit = identify_actuator([as_dataset(commands, readings)])
        assert not fit.identified and fit.law is None
        assert [f.code for f in fit.findings if f.severity == "error"] == ["actuator_readings_do_not_follow"]
        assert fit.describe().startswith("The actuator law was not identified")


def test_a_stuck_cable_is_named_and_left_out():
    rng = np.random.default_rng(8)
    commands = flop_commands(rng)
    readings = encoder_readings(commands, Actuator(delay=0.05, rate=1.4), rng)
    stuck = ACTUATED[1]
    readings[:, stuck] = readings[0, stuck] + rng.normal(0.0, 3e-4, readings.shape[0])
    fit = identify_actuator([as_dataset(commands, readings)])
    named = [f for f in fit.findings if f.code == "actuator_stuck_cable"]
    assert len(named) == 1 and CABLE_NAMES[stuck] in named[0].message
    assert stuck not in fit.actuated
    assert fit.delay_claimed and abs(fit.delay.value - 0.05) <= 1 / RATE


def test_gaps_and_a_jittered_clock_still_give_the_delay():
    rng = np.random.default_rng(9)
    commands = flop_commands(rng)
    readings = encoder_readings(commands, Actuator(delay=0.05, rate=1.4), rng)
    readings[rng.random(readings.shape) < 0.05] = np.nan
    commands = commands.copy()
    commands[rng.random(commands.shape) < 0.02] = np.nan
    ds = as_dataset(commands, readings)
    jitter = rng.uniform(-0.002, 0.002, ds.sizes["time"])
    ds = ds.assign_coords(time=ds["time"].values + jitter)
    keep = np.ones(ds.sizes["time"], bool)
    keep[rng.choice(np.arange(5, ds.sizes["time"] - 5), 8, replace=False)] = False
    fit = identify_actuator([ds.isel(time=keep)])
    assert fit.identified and fit.delay_claimed
    assert abs(fit.delay.value - 0.05) <= 1 / RATE
    assert abs(fit.interval - 1 / RATE) < 1e-5


def test_bad_input_gets_a_typed_one_line_error():
    rng = np.random.default_rng(10)
    commands = flop_commands(rng)
    ds = as_dataset(commands, commands)
    with pytest.raises(ActuatorReadingsError, match="rest_length"):
        identify_actuator([ds.drop_vars("rest_length")])
    with pytest.raises(ParameterError, match="folds"):
        ActuatorConfig(folds=1)
    with pytest.raises(ParameterError, match="no such part"):
        ActuatorLaw(form=LawForm(delay=True), delay=0.01, rate=1.0)
    with pytest.raises(ParameterError, match="delay"):
        ActuatorLaw(form=LawForm(delay=True), delay=-0.01)
    assert math.isinf(replace(ActuatorLaw(form=LawForm(rate_limit=True), rate=2.0), rate=math.inf).rate)


def test_commands_that_never_move_get_a_finding():
    rng = np.random.default_rng(11)
    commands = np.tile(flop_commands(rng)[0], (100, 1))
    fit = identify_actuator([as_dataset(commands, commands + 0.004)])
    assert not fit.identified and [f.code for f in fit.findings] == ["actuator_no_commands"]
    assert np.allclose(fit.offsets, 0.004)


def test_a_misfit_is_reported_when_it_persists_and_exceeds_a_millimetre():
    """A slow wobble the laws lack, added to exact readings: 5 mm of it is a misfit, 0.3 mm (the scale of
    marker noise in the cable lengths a tension limit reads) is not, though both persist over samples."""
    rng = np.random.default_rng(12)
    commands = flop_commands(rng)
    exact = encoder_readings(commands, Actuator(rate=1.4, noise=1e-5), rng)
    wobble = np.sin(2 * np.pi * 0.8 * np.arange(commands.shape[0]) / RATE)[:, None]
    codes = {amplitude: [f.code for f in identify_actuator([as_dataset(commands, exact + amplitude * wobble)]).findings]
             for amplitude in (3e-4, 5e-3)}
    assert "actuator_law_misfit" not in codes[3e-4]
    assert "actuator_law_misfit" in codes[5e-3]


@pytest.mark.slow
def test_the_library_motor_claims_no_delay_on_nominal_data(flop_data):
    """The library's motor (physics.actuators) lies outside the laws (a load-dependent droop, motor
    inertia): the law says so, claims no delay on nominal data, and with a 50 ms delay its interval
    still covers it."""
    from physics import FlopController, simulate
    from physics.effects.base import model_space
    from physics.effects.components import ActuatorDelay

    nominal = identify_actuator([flop_data])
    assert nominal.identified and not nominal.delay_claimed
    assert nominal.describe().startswith("The motors follow their commands with no delay")
    space = model_space((ActuatorDelay(),))
    theta = dict(zip(space.names, space.nominal, strict=True)) | {"actuator_delay": 0.05}
    delayed = simulate(theta, controller=FlopController(heading=0.0), duration=2.0, effects=(ActuatorDelay(),))
    fit = identify_actuator([delayed])
    assert fit.delay.low <= 0.05 <= fit.delay.high
