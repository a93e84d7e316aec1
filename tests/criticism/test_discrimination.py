"""Which flop tells two contenders apart (criticism.discrimination): the separation of their
predictions obeys what the effects are, and bad input is refused."""
from __future__ import annotations

import numpy as np
import pytest

from criticism.candidate import Candidate
from criticism.discrimination import flop_candidates, separations
from criticism.errors import CriticismError
from physics.controllers import FlopController
from physics.effects import SensorBias, model_space


def _bias(b: float) -> Candidate:
    """A contender 'sensor bias b' at the nominal θ (its joint fit)."""
    space = model_space((SensorBias(),))
    theta = space.as_array({**dict(zip(space.names, space.nominal, strict=True)), "sensor_bias_z": b})
    return Candidate("sensor_bias", "effect", {"sensor_bias_z": b}, 0.0, 0.0, 0.0, 0.0,
                     config=SensorBias().config(), stage="joint", theta=tuple(theta))


def test_a_pure_sensor_bias_separates_by_its_size_over_root_three_under_every_flop() -> None:
    # x_a - x_b = (0, 0, b_a - b_b) at every node and sample: s = |b_a - b_b| / sqrt(3), whatever the motion
    controllers = {"brief": FlopController(0.0, start=0.5, stop=0.6, period=1.0),
                   "flop": FlopController(1.0, n_cables=6, change=0.3)}
    seps = separations((), _bias(0.01), _bias(-0.002), controllers, duration=0.4)
    assert [s.rms for s in seps] == pytest.approx([0.012 / np.sqrt(3)] * 2, rel=1e-9)
    same = separations((), _bias(0.01), _bias(0.01), controllers, duration=0.4, recorded=["flop"])
    assert [s.rms for s in same] == [0.0, 0.0]    # the same model: the same trajectory, bit for bit
    assert {s.label: s.recorded for s in same} == {"brief": False, "flop": True}


def test_candidates_cover_each_heading_and_pattern_and_bad_input_is_refused() -> None:
    flops = flop_candidates(headings=3, patterns=((4, 0.2), (6, 0.3)))
    assert len(flops) == 6 and len(set(flops)) == 6
    assert sorted({round(u.heading, 6) for u in flops.values()}) == pytest.approx([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
    with pytest.raises(CriticismError, match="headings >= 1"):
        flop_candidates(headings=0)
    without_fit = Candidate("sensor_bias", "effect", {}, 0.0, 0.0, 0.0, 0.0, config=SensorBias().config())
    with pytest.raises(CriticismError, match="fitted parameter vectors"):
        separations((), without_fit, _bias(0.0), {"flop": FlopController()})
