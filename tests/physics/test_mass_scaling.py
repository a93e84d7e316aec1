"""The mass-scale symmetry (physics.scaling) by its law: every mass and force times λ, with the
model's default options (its constants of mass dimension follow the robot's mass by themselves),
and the robot moves exactly as before; hold those constants at fixed absolute values and the
motion changes, which is what such constants would tell a trajectory of the scale."""
from __future__ import annotations

import numpy as np
import pytest

from physics import FlopController, ModelOptions, MotorGains, ParameterError, ParameterSpace, T6Model, simulate
from physics.effects import (
    EFFECT_TYPES,
    AirDrag,
    CableAnchors,
    CableHysteresis,
    PointMass,
    RollingResistance,
    TensionLimitedActuation,
    ViscousDrag,
    model_space,
)
from physics.geometry import rod_mass_properties
from physics.scaling import (
    mass_dimension,
    mass_exponents,
    robot_mass,
    rod_mass_scale,
    scale_masses,
    scale_options,
    weighed,
)

LAM = 1.3
SIZES = {"drag": 5.0, "viscous_drag": 4.0, "point_mass": 1.0,
         "hysteresis": 0.3, "rolling_resistance": 0.3, "anchor_offset": 0.05}


def test_units_have_their_mass_dimension() -> None:
    assert [mass_dimension(u) for u in ("kg/m^3", "N*s/m", "kg*m^2", "N*s^2/m^2", "1/m", "m/s", "rad", "1")] == [
        1, 1, 1, 1, 0, 0, 0, 0]
    assert mass_dimension("kg^2/N") == 1
    t6 = dict(zip(ParameterSpace.t6().names, mass_exponents(ParameterSpace.t6()), strict=True))
    assert sorted(n for n, p in t6.items() if p) == ["damping", "density", "density_mp", "maxTens", "motor_friction",
                                                      "motor_inertia", "pretension", "stiffnessActive"]
    for cls in EFFECT_TYPES.values():                       # every catalog effect's unit is readable
        mass_exponents(model_space((cls(),)))


@pytest.mark.parametrize("unit", ["furlong", "N//m", "kg/m/s", "N*", "m^x"])
def test_an_unreadable_unit_is_refused(unit: str) -> None:
    with pytest.raises(ParameterError, match="unit"):
        mass_dimension(unit)


def _nodes(effects: tuple, theta: np.ndarray, options: ModelOptions) -> np.ndarray:
    ds = simulate(theta, controller=FlopController(heading=0.0), duration=0.6, settle=0.6, effects=effects,
                  space=model_space(effects), options=options)
    return ds.nodes.values


@pytest.mark.parametrize("effects", [(), (TensionLimitedActuation(), RollingResistance(), CableAnchors(), AirDrag(),
                                          ViscousDrag(), CableHysteresis(), PointMass())], ids=["T6", "augmented"])
def test_scaling_every_mass_and_force_leaves_the_motion_unchanged(effects: tuple) -> None:
    space = model_space(effects)
    theta = space.nominal.copy()
    for name, value in SIZES.items():
        if name in space.names:
            theta[space.names.index(name)] = value
    options = ModelOptions()
    before = _nodes(effects, theta, options)
    after = _nodes(effects, scale_masses(space, theta, LAM), options)       # the same options: the same motion
    assert np.abs(after - before).max() < 1e-9                    # measured: 1e-14 m (rounding)
    heavier = theta.copy()
    heavier[space.names.index("density")] *= LAM                  # a mass alone: a different motion
    assert np.abs(_nodes(effects, heavier, options) - before).max() > 0.01
    held = scale_options(options, 1.0 / LAM)          # spin damping and K_v held at their values at θ: the scale shows
    fixed = _nodes(effects, scale_masses(space, theta, LAM), held)
    assert np.abs(fixed - before).max() > 1e-4


def test_the_constants_follow_the_rod_mass() -> None:
    space = ParameterSpace.t6()
    theta = space.nominal.copy()
    theta[space.names.index("radius_mp")] *= 1.05
    params = dict(zip(space.names, theta, strict=True))
    scaled = dict(zip(space.names, scale_masses(space, theta, LAM), strict=True))
    assert rod_mass_scale(dict(zip(space.names, space.nominal, strict=True))) == 1.0
    assert rod_mass_scale(scaled) == pytest.approx(LAM * rod_mass_scale(params), rel=1e-14)
    assert rod_mass_scale(params) == pytest.approx(robot_mass(space, theta) / robot_mass(space, space.nominal))
    model = T6Model(theta)
    assert model.mass_scale == rod_mass_scale(params)
    assert model.setup.gains.kv == pytest.approx(ModelOptions().motor.kv * model.mass_scale)
    options = ModelOptions(spin_damping=1.5, motor=MotorGains(kv=0.2))
    assert options.spin_damping_at(2.0) == 3.0 and options.motor_at(2.0) == MotorGains(kv=0.4)
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ParameterError, match="mass scale"):
            options.motor_at(bad)
    with pytest.raises(ParameterError, match="rod parameters"):
        rod_mass_scale({"density": 1.0})


def test_weighed_moves_theta_to_the_mass_and_keeps_the_rest() -> None:
    space = model_space((PointMass(),))
    theta = space.nominal.copy()
    theta[space.names.index("point_mass")] = 0.5
    rod = rod_mass_properties(*(theta[space.names.index(n)] for n in ("density", "radius", "density_mp", "radius_mp",
                                                                        "rod_length", "rod_length_mp")))
    assert robot_mass(space, theta) == pytest.approx(6 * rod.mass + 0.5)
    rows = np.stack([theta, scale_masses(space, theta, 0.8)])
    moved = weighed(space, rows, 20.0)
    assert robot_mass(space, moved) == pytest.approx([20.0, 20.0])
    kinematic = mass_exponents(space) == 0
    assert np.array_equal(moved[:, kinematic], rows[:, kinematic])
    assert np.allclose(moved[0], moved[1])                         # one orbit, one point of it at 20 kg
    with pytest.raises(ParameterError, match="weighed mass"):
        weighed(space, theta, -1.0)
    with pytest.raises(ParameterError, match="rod parameters"):
        robot_mass(ParameterSpace(ParameterSpace.t6().parameters[:1]), theta[:1])
