"""The actuator read from the encoders as the model's actuator (issue 68, item 2): the model steps the
law exactly as the stage predicts it, the choice keeps the motor where the motor explains the
readings and takes the law where it does not, and the motor parameters become inert."""
from __future__ import annotations

import numpy as np
import pytest

from criticism.mismatch import superseded
from physics import FlopController, ParameterSpace, simulate
from physics.actuator_choice import choose_actuator, has_readings
from physics.effects import (
    MOTOR_PARAMETERS,
    ActuatorDelay,
    AirDrag,
    MeasuredActuator,
    RateLimitedActuation,
    TensionLimitedActuation,
    effect_from_config,
    model_space,
)
from physics.errors import ParameterError
from physics.measurements import MeasurementPrior, measurement_prior_from_args

NOMINAL = ParameterSpace.t6().nominal


def _flop(effect: MeasuredActuator | None, heading: float = 0.0, duration: float = 1.5, seed: int = 0):
    effects = () if effect is None else (effect,)
    theta = dict(zip(model_space(effects).names, NOMINAL, strict=True))
    return simulate(theta, controller=FlopController(heading=heading), duration=duration, effects=effects, seed=seed)


@pytest.mark.parametrize("law", [
    {"delay": 0.05, "rate": 0.3, "time_constant": 0.02},
    {"rate": 0.4},
    {"delay": 0.03, "time_constant": 0.05},
])
def test_the_model_steps_the_law_exactly_as_the_stage_predicts_the_readings(law) -> None:
    """Rest lengths of a simulation with the measured actuator = ActuatorLaw.predict of its commands
    (both integrate each interval exactly), on every cable."""
    effect = MeasuredActuator(**law)
    ds = _flop(effect)
    interval = float(ds.time[1] - ds.time[0])
    predicted = effect.law.predict(np.asarray(ds.controls.values, float), interval)
    readings = np.asarray(ds.rest_length.values, float)
    assert np.ptp(readings, axis=0).max() > 0.05               # the flop moves cables
    assert np.max(np.abs(predicted - readings)) < 1e-9


def test_an_offset_moves_its_cable_only() -> None:
    """A cable's offset o: its rest length settles o off its command, every other cable on its own."""
    offsets = np.zeros(24)
    offsets[5] = 0.004
    ds = _flop(MeasuredActuator(rate=0.4, offsets=offsets.tolist()), duration=2.0)
    gap = np.asarray(ds.rest_length.values, float)[-1] - np.asarray(ds.controls.values, float)[-1]
    assert abs(gap[5] - 0.004) < 1e-9 and np.max(np.abs(np.delete(gap, 5))) < 1e-9


def test_a_rate_and_tension_limit_is_ntrts_basic_actuator() -> None:
    """The law with rate targetVelocity and slack maxTens / k is the tension-limited actuator at θ (the
    same rule, floor = L0 + T / k - s): the same flop to rounding; and a tight limit binds (the same
    flop pulls far less hard)."""
    space = ParameterSpace.t6()
    rate, slack = float(NOMINAL[space.index("targetVelocity")]), float(NOMINAL[space.index("maxTens")] /
                                                                       NOMINAL[space.index("stiffnessActive")])
    law = _flop(MeasuredActuator(rate=rate, tension_slack=slack), duration=2.0)
    theta = dict(zip(space.names, NOMINAL, strict=True))
    ntrt = simulate(theta, controller=FlopController(heading=0.0), duration=2.0,
                    effects=(TensionLimitedActuation(),), seed=0)
    assert np.max(np.abs(law.nodes.values - ntrt.nodes.values)) < 1e-6
    assert np.max(np.abs(law.rest_length.values - ntrt.rest_length.values)) < 1e-6
    free = _flop(MeasuredActuator(rate=rate), duration=2.0)
    tight = _flop(MeasuredActuator(rate=rate, tension_slack=0.1), duration=2.0)
    assert float(tight.tension.max()) < 0.6 * float(free.tension.max())


def test_the_measured_actuator_is_a_component_without_parameters_that_supersedes_the_actuator_effects() -> None:
    effect = MeasuredActuator(delay=0.05, rate=1.2, tension_slack=0.3, offsets=[0.001] * 24)
    assert effect_from_config(effect.config()) == effect
    assert model_space((effect,)).names == ParameterSpace.t6().names and effect.off is None
    tries = [ActuatorDelay(), RateLimitedActuation(), TensionLimitedActuation(), AirDrag()]
    assert [e.name for e in superseded(tries, [effect])] == ["air_drag"]
    assert effect.inert == MOTOR_PARAMETERS
    with pytest.raises(ParameterError, match="24 values"):
        MeasuredActuator(offsets=[0.0, 1.0])


@pytest.fixture(scope="module")
def law_flops():
    """Three flops of the library's robot driven by a law actuator the motor model is not (50 ms late,
    0.3 m/s): readings no motor at nominal θ explains."""
    effect = MeasuredActuator(delay=0.05, rate=0.3)
    return [_flop(effect, heading=h, duration=2.0, seed=k) for k, h in enumerate((0.0, 2.1, 4.2))]


def test_the_choice_takes_the_law_where_the_motor_misses_the_readings(law_flops) -> None:
    choice = choose_actuator(law_flops, ParameterSpace.t6())
    assert choice is not None and choice.measured and choice.effect is not None
    assert abs(choice.effect.law.delay - 0.05) < 0.01 and abs(choice.effect.law.rate - 0.3) < 0.015
    assert choice.law_rms < 0.1 * choice.motor_rms and choice.inert == MOTOR_PARAMETERS
    assert "the measured law is the model's actuator" in choice.lines()[1]
    assert choice.as_dict()["effect"] == choice.effect.config()
    assert choose_actuator(law_flops, ParameterSpace.t6(), mode="model") is None


def test_the_choice_keeps_the_motor_whose_own_readings_it_explains() -> None:
    flops = [_flop(None, heading=h, duration=2.0, seed=k) for k, h in enumerate((0.0, 2.1))]
    choice = choose_actuator(flops, ParameterSpace.t6())
    assert choice is not None and not choice.measured and choice.inert == ()
    assert choice.motor_rms < 1e-3 and "keeps its motor" in choice.reason
    measured = choose_actuator(flops, ParameterSpace.t6(), mode="measured")
    assert measured is not None and measured.measured           # asked for: the law even where it fits worse


def test_without_readings_nothing_changes_unless_the_law_is_demanded(law_flops) -> None:
    bare = [ds.drop_vars("rest_length") for ds in law_flops]
    assert not has_readings(bare) and has_readings(law_flops)
    assert choose_actuator(bare, ParameterSpace.t6()) is None
    with pytest.raises(ParameterError, match="needs encoder readings"):
        choose_actuator(bare, ParameterSpace.t6(), mode="measured")
    with pytest.raises(ParameterError, match="actuator mode"):
        choose_actuator(law_flops, ParameterSpace.t6(), mode="motor")        # type: ignore[arg-type]


def test_inert_parameters_are_held_apart_from_the_users_and_survive_a_record() -> None:
    import argparse

    from physics.measurements import add_measurement_options

    parser = argparse.ArgumentParser()
    add_measurement_options(parser)
    space = ParameterSpace.t6()
    known = measurement_prior_from_args(parser.parse_args(["--fix", "maxTens=310", "--measured",
                                                           "motor_radius=0.009+-0.0003"]), space)
    held = known.with_inert(MOTOR_PARAMETERS)
    assert held.fixed["maxTens"] == 310                       # the user's value stands
    assert held.inert == ("targetVelocity", "motor_friction", "motor_inertia")   # measured radius stays free
    assert held.free_space.dim == 15 - 4
    text = held.summary()
    assert "Fixed by the user (not identified):\n  maxTens = 310" in text
    assert "inert (the measured actuator replaces the motor that read them): targetVelocity" in text
    back = MeasurementPrior.from_config(held.config(), space)
    assert back.inert == held.inert and dict(back.fixed) == dict(held.fixed)
