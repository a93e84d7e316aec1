"""What the user knows (physics.measurements, physics.quantities): parsing, every refusal with its
one-line message, the derived quantities against hand computation, and the measurement prior
(its residuals, density, Jacobian in the unit box and record)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from physics.errors import MeasurementError, ParameterError, TensegridError
from physics.geometry import rod_mass_properties
from physics.measurements import (
    QUANTITIES,
    Measurement,
    MeasurementPrior,
    check_measurements,
    measured_values,
    parse_fixed,
    parse_measurement,
    rod_inertia,
    rod_mass,
    total_mass,
)
from physics.parameters import Parameter, ParameterSpace
from physics.push import PushObjective, generate_push_data, push_space
from physics.quantities import depends_on, known_quantities, quantity_range

T6 = ParameterSpace.t6()
ROD = ("density", "radius", "density_mp", "radius_mp", "rod_length", "rod_length_mp")


# ---------------------------------------------------------------------------------------------------- parsing
@pytest.mark.parametrize("text", ["rod_mass=3.02+-0.05", "rod_mass=3.02±0.05", " rod_mass = 3.02 ± 0.05 ",
                                  "rod_mass=3.02 +/- 0.05", "rod_mass=302e-2+-5e-2"])
def test_both_forms_parse_to_the_same_measurement(text: str) -> None:
    assert parse_measurement(text) == Measurement("rod_mass", 3.02, 0.05)


def test_fixed_values_parse_with_spaces() -> None:
    assert parse_fixed("rod_length=1.74") == ("rod_length", 1.74)
    assert parse_fixed(" motor_friction = 8.5e-5 ") == ("motor_friction", 8.5e-5)


@pytest.mark.parametrize(("text", "says"), [
    ("rod_mass", "is not of the form NAME=VALUE+-SD or NAME=VALUE±SD in SI units, e.g. rod_mass=3.02+-0.05"),
    ("rod_mass=3.02", "a value without an uncertainty is fixed: --fix NAME=VALUE"),
    ("rod_mass=heavy+-0.1", "'rod_mass=heavy+-0.1' is not of the form"),
    ("=3+-1", "is not of the form"),
    ("rod_mass=3.02+-", "is not of the form"),
])
def test_a_malformed_measurement_names_the_right_form(text: str, says: str) -> None:
    with pytest.raises(MeasurementError, match=re_escape(says)):
        parse_measurement(text)


@pytest.mark.parametrize(("text", "says"), [
    ("rod_length", "is not of the form NAME=VALUE in SI units, e.g. rod_length=1.74"),
    ("rod_length=1.74+-0.01", "a value with an uncertainty is measured: --measured NAME=VALUE+-SD"),
    ("rod_length=long", "is not of the form"),
])
def test_a_malformed_fixed_value_names_the_right_form(text: str, says: str) -> None:
    with pytest.raises(MeasurementError, match=re_escape(says)):
        parse_fixed(text)


@pytest.mark.parametrize(("args", "says"), [
    (("rod_mass", 3.0, 0.0), "the standard deviation must be a finite number > 0, got 0.0"),
    (("rod_mass", 3.0, -0.1), "the standard deviation must be a finite number > 0, got -0.1"),
    (("rod_mass", 3.0, math.inf), "the standard deviation must be a finite number > 0, got inf"),
    (("rod_mass", math.nan, 0.1), "the value must be finite"),
    (("rod mass", 3.0, 0.1), "a measurement names a quantity"),
    (("rod_mass", "3", 0.1), "value must be a number"),
    (("rod_mass", 3.0, True), "sd must be a number"),
])
def test_a_measurement_is_validated(args: tuple, says: str) -> None:
    with pytest.raises(MeasurementError, match=re_escape(says)):
        Measurement(*args)


def test_measurement_error_is_a_parameter_error_and_a_value_error() -> None:
    assert issubclass(MeasurementError, ParameterError) and issubclass(MeasurementError, TensegridError)
    assert issubclass(MeasurementError, ValueError)


# ------------------------------------------------------------------------------------------------ refusals
def _m(name: str, value: float, sd: float = 0.01) -> Measurement:
    return Measurement(name, value, sd)


@pytest.mark.parametrize(("measured", "fixed", "says"), [
    ([_m("rod_mas", 3.0)], {}, "measured rod_mas: unknown quantity; the known ones are rod_mass, total_mass, "
                                "rod_inertia, density, radius"),
    ([_m("rod_mass", 3000.0)], {}, "measured rod_mass=3000 kg is 1000 times the box's range 1.52-5.23 kg: the unit is "
                                   "kg (did you give grams?)"),
    ([_m("rod_length", 1740.0)], {}, "is 1000 times the box's range 1.57-1.91 m: the unit is m (did you give "
                                     "millimetres?)"),
    ([_m("rod_length", 174.0)], {}, "(did you give centimetres?)"),
    ([_m("density", 0.311)], {}, "is 1/1000 of the box's range 280-342 kg/m^3: the unit is kg/m^3 (did you give "
                                 "g/cm^3?)"),
    ([_m("rod_inertia", 1.3e6)], {}, "(did you give kg*mm^2?)"),
    ([_m("rod_length", 2.5)], {}, "measured rod_length=2.5 m lies outside the range 1.566-1.914 m that the prior box "
                                  "allows; widen the box with --bounds rod_length=LO:HI or --nominal rod_length=VALUE"),
    ([_m("rod_mass", 6.0)], {}, "lies outside the range 1.516-5.227 kg that the prior box allows; widen the box "
                                "with --bounds NAME=LO:HI or --nominal NAME=VALUE on density, radius, density_mp, "
                                "radius_mp, rod_length, rod_length_mp"),
    ([_m("rod_mass", -3.0)], {}, "measured rod_mass=-3 kg is impossible: it must be > 0 kg"),
    ([_m("total_mass", 0.0)], {}, "measured total_mass=0 kg is impossible"),
    ([_m("rod_inertia", -1.0)], {}, "measured rod_inertia=-1 kg*m^2 is impossible"),
    ([_m("rod_length", 0.0)], {}, "measured rod_length=0 m is impossible: it must be > 0 m"),
    ([_m("damping", -1.0)], {}, "measured damping=-1 N*s/m is impossible: it must be >= 0 N*s/m"),
    ([_m("rod_length", 1.7)], {"rod_length": 1.7}, "rod_length is both fixed and measured"),
    ([_m("rod_mass", 3.0), _m("rod_mass", 3.1)], {}, "measured rod_mass is given twice"),
    ([], [("damping", 200.0), ("damping", 190.0)], "fixed damping is given twice; give each name once (keep one"),
    ([], {"damping": math.inf}, "fixed damping=inf: give a finite number in N*s/m"),
    ([], {"rod_mass": 3.0}, "fixed rod_mass: only a parameter can be fixed; rod_mass is derived from density, "
                            "radius, density_mp, radius_mp, rod_length, rod_length_mp: measure it"),
    ([], {"rod_lenght": 1.7}, "fixed rod_lenght: only a parameter can be fixed; the parameters are density, radius"),
    ([], {"rod_length": 2.5}, "fixed rod_length=2.5 m lies outside the range 1.566-1.914 m"),
    ([], {"motor_friction": 0.1}, "fixed motor_friction=0.1 N*m*s is 1200 times the box's range"),
    ([], {"rod_length": -1.7}, "fixed rod_length=-1.7 m is impossible"),
])
def test_each_refusal_is_one_line_naming_the_problem_and_the_fix(measured, fixed, says: str) -> None:
    with pytest.raises(MeasurementError, match=re_escape(says)) as info:
        check_measurements(T6, measured, fixed)
    assert "\n" not in str(info.value)


def test_a_widened_box_accepts_what_the_default_refuses() -> None:
    wide = T6.with_overrides(bounds={"rod_length": (1.5, 2.6)})
    check_measurements(wide, [_m("rod_length", 2.5)], {})
    check_measurements(T6.with_overrides(bounds={"motor_friction": (0.05, 0.2)}), [], {"motor_friction": 0.1})


def test_the_push_toy_knows_its_own_parameters_only() -> None:
    assert known_quantities(push_space()) == ("m", "mu")
    with pytest.raises(MeasurementError, match=re_escape("unknown quantity; the known ones are m, mu.")):
        check_measurements(push_space(), [_m("rod_mass", 3.0)])
    with pytest.raises(MeasurementError, match="every parameter of the space is fixed"):
        check_measurements(push_space(), [], {"m": 1.0, "mu": 0.4})
    check_measurements(push_space(), [_m("m", 1.0, 0.1)], {"mu": 0.4})


# ---------------------------------------------------------------------------------------------- quantities
def test_rod_quantities_against_hand_computation() -> None:
    rho, r, rho_mp, r_mp, length, l_mp = (T6[n].nominal for n in ROD)
    l_e = (length - l_mp) / 2
    by_hand = 2 * rho * math.pi * r**2 * l_e + rho_mp * math.pi * r_mp**2 * l_mp       # 3.003 kg
    assert rod_mass(T6, T6.nominal) == pytest.approx([by_hand], rel=1e-12)
    assert by_hand == pytest.approx(3.003, abs=1e-3)
    assert total_mass(T6, T6.nominal) == pytest.approx(6 * rod_mass(T6, T6.nominal), rel=1e-12)
    rows = T6.sample(5, seed=1)
    props = [rod_mass_properties(*(row[T6.index(n)] for n in ROD)) for row in rows]
    np.testing.assert_allclose(rod_mass(T6, rows), [p.mass for p in props], rtol=1e-12)
    np.testing.assert_allclose(rod_inertia(T6, rows), [p.transverse for p in props], rtol=1e-12)
    np.testing.assert_allclose(measured_values(T6, rows, "rod_length"), rows[:, T6.index("rod_length")])
    assert rod_mass(T6, rows).shape == (5,) and measured_values(T6, rows[0], "rod_inertia").shape == (1,)


def test_total_mass_adds_a_point_mass_when_the_space_has_one() -> None:
    extra = Parameter("point_mass", "kg", 0.5, 0.0, 3.0, "extra mass", strict=False)
    space = ParameterSpace.from_parameters([*T6, extra])
    theta = space.nominal
    assert total_mass(space, theta) == pytest.approx(6 * rod_mass(space, theta) + 0.5, rel=1e-12)
    assert depends_on(space, "total_mass") == (*ROD, "point_mass") and depends_on(space, "rod_mass") == ROD
    assert set(QUANTITIES) == {"rod_mass", "total_mass", "rod_inertia"}


def test_the_box_range_holds_every_value_in_the_box() -> None:
    rows = T6.sample(200, seed=2)
    for name in QUANTITIES:
        lo, hi = quantity_range(T6, name)
        values = measured_values(T6, rows, name)
        assert lo <= values.min() and values.max() <= hi, name
        assert lo <= measured_values(T6, T6.nominal, name)[0] <= hi
    assert quantity_range(T6, "rod_length") == (T6["rod_length"].lower, T6["rod_length"].upper)


# --------------------------------------------------------------------------------------------------- prior
def _prior(**fixed: float) -> MeasurementPrior:
    return MeasurementPrior(T6, (Measurement("rod_mass", 3.1, 0.05), Measurement("rod_length", 1.70, 0.01),
                                 Measurement("rod_inertia", 1.3, 0.02)), fixed)


def test_residuals_are_standardized_and_the_density_peaks_at_the_measured_value() -> None:
    prior = MeasurementPrior(T6, (Measurement("rod_length", 1.70, 0.01),))
    lengths = np.linspace(1.6, 1.8, 21)
    thetas = np.array([T6.replace(rod_length=v) for v in lengths])
    np.testing.assert_allclose(prior.residuals(thetas)[:, 0], (lengths - 1.70) / 0.01, atol=1e-9)
    density = prior.log_density(thetas)
    assert lengths[np.argmax(density)] == pytest.approx(1.70) and density.max() == pytest.approx(0.0, abs=1e-18)
    mass_prior = MeasurementPrior(T6, (Measurement("rod_mass", float(rod_mass(T6, thetas[3])[0]), 0.05),))
    others = mass_prior.log_density(thetas)
    assert others[3] == pytest.approx(0.0, abs=1e-20) and np.all(np.delete(others, 3) < 0)


def test_the_prior_takes_rows_of_the_free_parameters() -> None:
    prior = _prior(rod_length_mp=1.0, damping=200.0)
    assert prior.free_space.names == tuple(n for n in T6.names if n not in ("rod_length_mp", "damping"))
    free = prior.free_space.sample(4, seed=0)
    full = prior.full(free)
    assert full.shape == (4, 15) and np.all(full[:, T6.index("damping")] == 200.0)
    np.testing.assert_array_equal(prior.free(full), free)
    np.testing.assert_allclose(prior.values(free)[:, 0], rod_mass(T6, full))
    assert prior.residuals(free).shape == (4, 3) and prior.log_density(free).shape == (4,)
    with pytest.raises(ParameterError, match="θ of the free parameters must have shape"):
        prior.residuals(T6.nominal)


@pytest.mark.parametrize("fixed", [{}, {"rod_length_mp": 1.05, "radius": 0.058}])
def test_the_jacobian_in_the_unit_box_matches_finite_differences(fixed: dict[str, float]) -> None:
    prior = _prior(**fixed)
    space = prior.free_space
    u = np.random.default_rng(4).uniform(0.2, 0.8, space.dim)
    G = prior.jacobian(space.from_unit(u))
    assert G.shape == (3, space.dim)
    h = 1e-4
    for j in range(space.dim):
        step = np.zeros(space.dim)
        step[j] = h
        pair = prior.residuals(space.from_unit(np.vstack([u + step, u - step])))
        np.testing.assert_allclose(G[:, j], (pair[0] - pair[1]) / (2 * h), rtol=1e-5, atol=1e-8)
    length = space.index("rod_length")
    assert G[1, length] == pytest.approx((space.upper[length] - space.lower[length]) / 0.01)
    assert np.count_nonzero(G[1]) == 1 and G[0, space.index("damping")] == 0.0


def test_the_jacobian_stays_in_the_box_at_its_faces() -> None:
    prior = _prior()
    corner = T6.lower.copy()
    G = prior.jacobian(corner)
    assert np.isfinite(G).all() and G[0, T6.index("density")] > 0


def test_the_record_round_trips_as_json() -> None:
    prior = _prior(damping=190.0)
    record = json.loads(json.dumps(prior.config()))
    assert record["measurements"][0] == {"name": "rod_mass", "value": 3.1, "sd": 0.05, "unit": "kg"}
    assert record["fixed"] == {"damping": 190.0}
    assert MeasurementPrior.from_config(record, T6) == prior
    with pytest.raises(MeasurementError, match="not a MeasurementPrior record"):
        MeasurementPrior.from_config({"kind": "box"}, T6)
    record["measurements"][1]["unit"] = "mm"
    with pytest.raises(MeasurementError, match=re_escape("measures rod_length in 'mm', the space in 'm'")):
        MeasurementPrior.from_config(record, T6)


def test_the_prior_validates_and_summarizes() -> None:
    with pytest.raises(MeasurementError, match="must be Measurement objects"):
        MeasurementPrior(T6, (("rod_mass", 3.0, 0.1),))     # type: ignore[arg-type]
    with pytest.raises(MeasurementError, match="is 1000 times the box's range"):
        MeasurementPrior(T6, (Measurement("rod_mass", 3000.0, 10.0),))
    text = _prior(damping=190.0).summary()
    assert text.splitlines()[0] == "Measured by the user:"
    assert "  rod_mass = 3.1 ± 0.05 kg  (mass of one rod)" in text and "  damping = 190 N*s/m" in text
    assert MeasurementPrior(T6).summary() == "" and MeasurementPrior(T6).residuals(T6.nominal).shape == (1, 0)


def test_hold_wraps_only_when_something_is_fixed() -> None:
    J, S = generate_push_data([1.0, 0.4], n=6, noise_std=0.05, seed=0)
    objective = PushObjective(J, S, noise_std=0.05)
    assert MeasurementPrior(push_space()).hold(objective) is objective
    held = MeasurementPrior(push_space(), (), {"mu": 0.4}).hold(objective)
    assert held.space.names == ("m",) and held(np.array([1.0])) == objective(np.array([1.0, 0.4]))
    with pytest.raises(MeasurementError, match="is not this prior's"):
        MeasurementPrior(push_space(mass=(0.5, 2.0)), (), {"mu": 0.4}).hold(objective)


def re_escape(text: str) -> str:
    import re

    return re.escape(text)
