"""Effects (physics.effects) by their laws: off means absent, the energy they store or dissipate,
the motion they cause, and the predictor seeing data made with them through the same model."""
from __future__ import annotations

import numpy as np
import pytest

from physics import FlopController, ModelOptions, ParameterError, T6Model, TrajectoryObjective, simulate
from physics.effects import (
    EFFECT_TYPES, ActuatorDelay, AirDrag, CableHysteresis, CylinderCaps, EndCapRadius, GroundSlope, NonlinearStiffness,
    PointMass, RateLimitedActuation, SensorBias, ViscousDrag, catalog, effect_from_config, model_space,
)
from physics.effects.world import (
    EVIDENT_TILT, MEASURED_CONTACT_WIDTH, MEASURED_SLOPE_WIDTH, contact_excess, resting_height, resting_tilt,
    slope_normal,
)
from physics.ground import ground_plane
from physics.scaling import robot_mass

FREE = ModelOptions(gravity=0.0, ground=False, spin_damping=0.0)


def _theta(effects, **values):
    space = model_space(effects)
    return space.as_array({**space.as_dict(None), **values}, check_bounds=False)


def _kicked(effects, options=FREE, **values):
    theta = _theta(effects, damping=0.0, motor_friction=0.0, **values)
    model = T6Model(theta, options=options, effects=effects)
    model._set_velocities(np.random.default_rng(3).normal(0.0, 0.3, 36))
    model.step(None, n=1)
    return model


def _energy_trace(model, chunks=20, steps=100):
    return np.array([model.energy()["total"]] + [model.step(None, n=steps) or model.energy()["total"]
                                                 for _ in range(chunks)])


def test_model_space_appends_effect_parameters_and_refuses_clashes():
    space = model_space([GroundSlope(), SensorBias()])
    assert space.names[15:] == ("slope_x", "slope_y", "sensor_bias_z") and space.dim == 18
    with pytest.raises(ParameterError, match="listed twice"):
        model_space([AirDrag(), AirDrag()])
    with pytest.raises(ParameterError, match="needs the T6 parameters"):
        T6Model(None, space=model_space([AirDrag()]))
    assert effect_from_config(PointMass(rod=3).config()) == PointMass(rod=3)
    with pytest.raises(ParameterError, match="unknown effect"):
        effect_from_config({"effect": "magic"})
    names = [e.name for e in catalog()]
    assert names == list(EFFECT_TYPES)[:11] and "encoder_offset" not in names


@pytest.mark.parametrize("effect", [t() for t in EFFECT_TYPES.values() if t.switchable], ids=lambda e: e.name)
def test_an_effect_at_its_off_value_is_the_model_without_it(effect):
    plain = T6Model(options=ModelOptions(drop_height=0.05))
    with_off = T6Model(_theta([effect]), effects=[effect], options=ModelOptions(drop_height=0.05))
    plain.step(None, n=200)
    with_off.step(None, n=200)
    np.testing.assert_array_equal(with_off.node_positions(), plain.node_positions())
    np.testing.assert_array_equal(with_off.observe(with_off.node_positions()), plain.node_positions())


def test_nonlinear_cables_conserve_energy_with_their_cubic_potential():
    effects = [NonlinearStiffness()]
    totals = _energy_trace(_kicked(effects, stiffness_quadratic=4.0))
    assert np.abs(totals - totals[0]).max() / totals[0] < 0.01


@pytest.mark.parametrize("effect, values", [(CableHysteresis(), {"hysteresis": 0.5}), (AirDrag(), {"drag": 5.0}),
                                           (ViscousDrag(), {"viscous_drag": 3.0})],
                         ids=["hysteresis", "drag", "viscous_drag"])
def test_hysteresis_and_drag_dissipate(effect, values):
    """Hysteresis stores path-dependent energy (the ½ k s² of energy() is not its potential), so
    only the net loss is asserted; drag loses energy at every step."""
    model = _kicked([effect], **values)
    kick = model.energy()["kinetic"]
    totals = _energy_trace(model)
    assert totals[0] - totals[-1] > 0.05 * kick               # loses a part of the kick
    if effect.name in ("air_drag", "viscous_drag"):           # drag, a force against the motion, never adds
        assert np.all(np.diff(totals) < 1e-3 * kick)
    free = _energy_trace(_kicked([effect]))                  # at the off value it conserves it
    assert np.abs(free - free[0]).max() < 0.01 * free[0]


def test_viscous_drag_slows_the_centre_of_mass_exponentially():
    """With F_n = -c v_n on the 12 ends of six equal rods, the total momentum obeys dP/dt =
    -2c Σ_r v_r = -(12 c / M) P whatever the cables do: v_com(t) = v_com(0) exp(-12 c t / M)."""
    effects, c = [ViscousDrag()], 3.0
    model = _kicked(effects, viscous_drag=c)
    mass = float(robot_mass(model_space(effects), _theta(effects, viscous_drag=c)))

    def com_velocity() -> np.ndarray:
        start = model.com()
        model.step(None, n=1)
        return (model.com() - start) / FREE.dt

    v0 = com_velocity()
    model.step(None, n=499)
    v1 = com_velocity()
    expected = v0 * np.exp(-12 * c * 0.5 / mass)
    assert np.linalg.norm(v0) > 0.01 and np.linalg.norm(v0 - expected) > 0.1 * np.linalg.norm(v0)
    np.testing.assert_allclose(v1, expected, rtol=0.01, atol=1e-3 * np.linalg.norm(v0))


def test_a_sloped_floor_keeps_gravity_vertical_and_tilts_the_ground_plane():
    effects = [GroundSlope()]
    model = T6Model(_theta(effects, slope_x=0.1), effects=effects, options=ModelOptions(ground=False))
    start = model.com()
    model.step(None, n=200)                                   # 0.2 s of free fall: straight down
    np.testing.assert_allclose(model.com() - start, [0.0, 0.0, -0.5 * 9.81 * 0.2**2], atol=2e-3)
    theta = _theta(effects, slope_x=0.06, slope_y=-0.04)
    rest = simulate(theta, effects=effects, duration=0.3, settle=1.5, sample_rate=100)
    plane = ground_plane(rest)                                # the data contract's world frame
    assert plane is not None
    assert np.degrees(np.arccos(plane.normal @ slope_normal(0.06, -0.04))) < 0.1
    assert plane.height == pytest.approx(0.06, abs=2e-3)      # contact nodes one cap radius off the floor


def test_a_slope_the_resting_robot_shows_is_measured_and_its_fit_kept_near_it():
    """GroundSlope.bind reads the tilt at rest (physics.ground): the bound effect's box is ± 0.5°
    around it and holds the true tilt; it survives its config; data that never rest leave it free."""
    effects = [GroundSlope()]
    rest = simulate(_theta(effects, slope_x=0.06, slope_y=-0.04), effects=effects, duration=0.3, settle=1.5,
                    sample_rate=100)
    bound = GroundSlope().bind([rest])
    assert isinstance(bound, GroundSlope) and bound.measured is not None
    for p, truth in zip(bound.parameters(), (0.06, -0.04), strict=True):
        assert p.lower < truth < p.upper and p.upper - p.lower == pytest.approx(2 * MEASURED_SLOPE_WIDTH)
    assert bound.off is None                                  # a measured floor is not switched off by a value
    assert effect_from_config(bound.config()) == bound and bound.bind([rest]) is bound
    assert GroundSlope().start([rest]) == pytest.approx({"slope_x": 0.06, "slope_y": -0.04}, abs=2e-3)
    assert bound.evident and not GroundSlope().evident         # 4.1°, seen at rest; unmeasured, nothing is
    flat = simulate(None, duration=0.3, settle=1.5, sample_rate=100)
    assert np.abs(GroundSlope().bind([flat]).measured).max() < np.radians(0.1)
    assert not GroundSlope().bind([flat]).evident
    assert GroundSlope(measured=(0.9 * EVIDENT_TILT, 0.0)).evident is False
    assert GroundSlope(measured=(1.1 * EVIDENT_TILT, 0.0)).evident is True
    falling = simulate(None, duration=0.5, settle=0.0, sample_rate=100, options=ModelOptions(ground=False))
    free = GroundSlope()
    assert resting_tilt([falling]) is None                    # a plane under moving nodes is no floor
    assert free.bind([falling]) is free


def test_a_bias_the_resting_robot_shows_is_measured_and_its_fit_kept_near_it():
    """SensorBias.bind reads the contact nodes' height at rest: seen at r + b, r the nominal radius,
    so the bound box is b ± MEASURED_CONTACT_WIDTH and holds the truth; level data without a bias
    bind near zero; data that never rest leave it free."""
    effects = [SensorBias()]
    rest = simulate(_theta(effects, sensor_bias_z=0.015), effects=effects, duration=0.3, settle=1.5,
                    sample_rate=100)
    assert resting_height([rest]) == pytest.approx(0.06 + 0.015, abs=2e-3)
    bound = SensorBias().bind([rest])
    assert isinstance(bound, SensorBias) and bound.measured == pytest.approx(0.015, abs=2e-3)
    (p,) = bound.parameters()
    assert p.lower < 0.015 < p.upper and p.upper - p.lower == pytest.approx(2 * MEASURED_CONTACT_WIDTH)
    assert p.lower > -0.05 + 0.015 - 1e-9                     # a sunken robot (b = -35 mm) is out of reach
    assert bound.off is None and effect_from_config(bound.config()) == bound and bound.bind([rest]) is bound
    flat = simulate(None, duration=0.3, settle=1.5, sample_rate=100)
    assert abs(SensorBias().bind([flat]).measured) < 2e-3
    falling = simulate(None, duration=0.5, settle=0.0, sample_rate=100, options=ModelOptions(ground=False))
    free = SensorBias()
    assert resting_height([falling]) is None and free.bind([falling]) is free
    with pytest.raises(ParameterError, match="width"):
        SensorBias(measured=0.0, width=0.0)


def test_a_cap_radius_the_resting_robot_shows_is_measured_and_kept_within_the_free_box():
    """EndCapRadius.bind reads Δr = h − r at rest and keeps ±MEASURED_CONTACT_WIDTH of it inside the
    free box: the true change is inside, a cap that would sink the resting robot 30 mm is not."""
    effects = [EndCapRadius()]
    rest = simulate(_theta(effects, cap_radius_change=-0.025), effects=effects, duration=0.3, settle=1.5,
                    sample_rate=100)
    assert contact_excess([rest]) == pytest.approx(-0.025, abs=2e-3)
    bound = EndCapRadius().bind([rest])
    assert isinstance(bound, EndCapRadius) and bound.measured == pytest.approx(-0.025, abs=2e-3)
    (p,) = bound.parameters()
    assert p.lower == EndCapRadius.FREE[0] and p.upper == pytest.approx(bound.measured + MEASURED_CONTACT_WIDTH)
    assert p.lower < -0.025 < p.upper and p.upper < 0.0      # no larger cap than the rod: the data rest lower
    assert bound.off is None and effect_from_config(bound.config()) == bound and bound.bind([rest]) is bound
    with pytest.raises(ParameterError, match="no change"):
        EndCapRadius(measured=0.2)                           # 20 cm above the floor: no cap in the box


def test_point_mass_adds_mass_and_moves_the_centre_of_mass_toward_it():
    effects = [PointMass(rod=0, position=1.0)]
    plain, heavy = T6Model(options=FREE), T6Model(_theta(effects, point_mass=2.0), effects=effects, options=FREE)
    assert heavy.robot.getMass() == pytest.approx(plain.robot.getMass() + 2.0)
    node = plain.node_positions()[1]
    assert np.linalg.norm(heavy.com() - node) < np.linalg.norm(plain.com() - node)


def test_an_unplaced_point_mass_offers_each_rod_and_end_and_builds_no_model():
    unplaced = [e for e in catalog() if e.name == "point_mass"][0]
    assert unplaced == PointMass(rod=None) and effect_from_config(unplaced.config()) == unplaced
    places = unplaced.placements()
    assert {(p.rod, p.position) for p in places} == {(r, s * 0.6) for r in range(6) for s in (1, -1)}
    assert all(p.placements() == (p,) for p in places) and len(set(places)) == 12
    assert [(p.rod, p.position) for p in PointMass(rod=None, position=0.0).placements()] == [(r, 0.0) for r in range(6)]
    with pytest.raises(ParameterError, match="no place to build a model"):
        T6Model(_theta([unplaced], point_mass=1.0), effects=[unplaced])


def test_caps_rest_on_their_contact_radius():
    effects = [EndCapRadius()]
    model = T6Model(_theta(effects, cap_radius_change=-0.03), effects=effects)
    model.settle(1.5)
    assert np.sort(model.node_positions()[:, 2])[:3] == pytest.approx(0.03, abs=3e-3)


def test_cylinder_caps_rest_on_the_rim_of_their_end_faces():
    """A rod tilted by α from the floor rests on its end face's rim: its lowest node r cos α high."""
    model = T6Model(_theta([CylinderCaps()]), effects=[CylinderCaps()])
    model.settle(1.5)
    nodes = model.node_positions()
    low = np.argsort(nodes[:, 2])[:3]
    axes = nodes[low ^ 1] - nodes[low]
    cos_tilt = np.linalg.norm(axes[:, :2], axis=1) / np.linalg.norm(axes, axis=1)
    radius = model.params["radius"]
    assert np.all(cos_tilt < 0.95)
    assert nodes[low, 2] == pytest.approx(radius * cos_tilt, abs=1e-3)


def test_delayed_commands_reach_the_actuators_after_the_delay():
    effects = [ActuatorDelay()]
    model = T6Model(_theta(effects, actuator_delay=0.05), effects=effects, options=FREE)
    start = model.rest_length.copy()
    model.step(model.rest_length_readings() * 0.8, n=49)
    np.testing.assert_array_equal(model.rest_length, start)   # nothing yet after 49 ms
    model.step(None, n=5)
    assert np.all(model.rest_length < start)


def test_rate_limited_actuator_moves_rest_lengths_at_its_rate():
    effects = [RateLimitedActuation()]
    model = T6Model(_theta(effects, actuator_rate=0.4), effects=effects, options=FREE)
    start = model.rest_length.copy()
    model.step(model.rest_length_readings() - 0.1, n=100)       # 0.1 s at 0.4 m/s: 0.04 m of 0.1 m
    np.testing.assert_allclose(start - model.rest_length, 0.04, rtol=1e-9)


@pytest.mark.parametrize("effect, values", [
    (ActuatorDelay(), {"actuator_delay": 0.08}), (RateLimitedActuation(), {"actuator_rate": 0.4}),
    (SensorBias(), {"sensor_bias_z": 0.02}), (CableHysteresis(), {"hysteresis": 0.5}),
], ids=lambda x: getattr(x, "name", ""))
def test_the_predictor_knows_an_effect_through_the_model(effect, values):
    """Data made with an effect: the one-step error of the model with it at the true value is at
    the floor of the model without effects on its own data (within 3×: the actuator state is
    reconstructed along the observed motion), the model without it is far worse."""
    theta = _theta([effect], **values)
    data = simulate(theta, controller=FlopController(0.0), duration=1.2, effects=[effect])
    plain_data = simulate(controller=FlopController(0.0), duration=1.2)
    floor = TrajectoryObjective(plain_data, loss="norm", n_workers=0)(None)
    wrong = TrajectoryObjective(data, loss="norm", n_workers=0)
    right = wrong.with_effects([effect])(theta)
    assert right < 3.0 * floor
    assert wrong(None) > 5.0 * right


def test_true_rest_lengths_in_the_data_give_the_same_error_as_encoder_readings():
    theta = _theta([], rod_length=1.70)
    kwargs = dict(controller=FlopController(0.0), duration=1.0)
    encoder = simulate(theta, **kwargs)
    true = simulate(theta, length_reference="true", **kwargs)
    assert true.attrs["length_reference"] == "true"
    assert not np.allclose(true.controls.values, encoder.controls.values)
    e_encoder = TrajectoryObjective(encoder, n_workers=0)(theta)
    assert TrajectoryObjective(true, n_workers=0)(theta) == pytest.approx(e_encoder, rel=1e-9)
