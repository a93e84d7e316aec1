from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st

from physics import T6_NOMINAL, Parameter, ParameterError, ParameterSpace


def test_t6_has_the_15_parameters_of_the_paper_with_reference_values():
    space = ParameterSpace.t6()
    assert space.dim == 15
    assert space.names[0] == "density" and space.names[-1] == "motor_inertia"
    assert space["pretension"].nominal == 150.0 and space["pretension"].unit == "N"
    np.testing.assert_allclose(space.lower, 0.9 * space.nominal)
    np.testing.assert_allclose(space.upper, 1.1 * space.nominal)
    assert dict(zip(space.names, space.nominal)) == dict(T6_NOMINAL)


def test_bounds_are_user_settable():
    space = ParameterSpace.t6(relative_width=0.2, bounds={"damping": (100.0, 300.0)})
    assert space["damping"].lower == 100.0 and space["damping"].upper == 300.0
    assert np.isclose(space["density"].upper, 311 * 1.2)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=15, max_size=15))
def test_unit_cube_round_trip(u):
    space = ParameterSpace.t6()
    theta = space.from_unit(np.array(u))
    assert np.all(theta >= space.lower - 1e-12) and np.all(theta <= space.upper + 1e-12)
    np.testing.assert_allclose(space.to_unit(theta), u, atol=1e-12)


def test_accepts_mapping_dataarray_and_batches():
    space = ParameterSpace.t6()
    th = space.as_array({"damping": 190.0})
    assert th[space.index("damping")] == 190.0 and th[0] == 311.0
    da = space.to_dataarray(space.nominal)
    np.testing.assert_array_equal(space.as_array(da.isel(parameter=slice(None, None, -1))), space.nominal)
    batch = space.sample(5, seed=1)
    assert batch.shape == (5, 15)
    np.testing.assert_array_equal(batch, space.sample(5, seed=1))


@pytest.mark.parametrize("theta, match", [
    (np.full(14, 1.0), r"shape \(15,\)"),
    (np.r_[np.nan, ParameterSpace.t6().nominal[1:]], r"'density' is NaN"),
    (ParameterSpace.t6().replace(density=400.0), r"'density' = 400.0 .* outside its bounds"),
    ({"densty": 300.0}, r"Unknown parameter name\(s\) \['densty'\]"),
    ("abc", r"theta must be numeric"),
    (xr.DataArray(np.ones(15), dims=["p"]), r"'parameter' dimension"),
])
def test_invalid_theta_raises_typed_errors(theta, match):
    with pytest.raises(ParameterError, match=match):
        ParameterSpace.t6().as_array(theta)


def test_non_physical_values_are_rejected_even_without_bounds():
    space = ParameterSpace.t6()
    with pytest.raises(ParameterError, match=r"'radius' = -0.01 m is non-physical"):
        space.replace(radius=-0.01)
    assert space.replace(damping=0.0)[space.index("damping")] == 0.0   # zero damping is physical
    with pytest.raises(ParameterError, match="non-physical"):
        space.replace(stiffnessActive=0.0)


@pytest.mark.parametrize("kwargs, match", [
    (dict(name="a b", unit="m", nominal=1, lower=0.5, upper=2), "identifier"),
    (dict(name="a", unit="m", nominal=1, lower=2, upper=1), "lower bound must be below"),
    (dict(name="a", unit="m", nominal=float("nan"), lower=0.5, upper=2), "finite"),
    (dict(name="a", unit="m", nominal=1, lower=-1, upper=2), "non-physical"),
])
def test_invalid_parameter_definitions(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        Parameter(**kwargs)


def test_space_validation():
    p = Parameter("a", "m", 1.0, 0.5, 2.0)
    with pytest.raises(ParameterError, match="duplicate"):
        ParameterSpace((p, p))
    with pytest.raises(ParameterError, match="at least one"):
        ParameterSpace(())
    with pytest.raises(ParameterError, match="relative_width"):
        ParameterSpace.t6(relative_width=1.5)
    with pytest.raises(ParameterError, match="Unknown T6 parameter"):
        ParameterSpace.t6(bounds={"mass": (1, 2)})
    with pytest.raises(ParameterError, match="unit cube"):
        ParameterSpace((p,)).from_unit([1.5])


def test_same_box_compares_names_order_and_bounds() -> None:
    from physics.parameters import ParameterSpace
    from physics.push import push_space

    t6 = ParameterSpace.t6()
    assert t6.same_box(ParameterSpace.t6())
    assert not t6.same_box(push_space())
    assert not t6.same_box(ParameterSpace.t6(relative_width=0.2))
