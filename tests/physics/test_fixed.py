"""FixedParameters (physics.fixed): the objective over the free parameters is the full one with the
fixed values put in, for E, parts, batches and residuals; its space, fingerprint and refusals.
(The objective contract itself is checked in tests/conformance/test_objective_contract.py.)"""
from __future__ import annotations

import re

import numpy as np
import pytest

from physics.errors import MeasurementError, ParameterError
from physics.fixed import FixedParameters, free_space, insert_fixed
from physics.objective import FunctionObjective, Objective
from physics.parameters import ParameterSpace
from physics.push import PushObjective, generate_push_data, push_space


@pytest.fixture
def push() -> PushObjective:
    J, S = generate_push_data([1.0, 0.4], n=6, noise_std=0.05, seed=0)
    return PushObjective(J, S, noise_std=0.05, windows=3)


def test_it_evaluates_the_full_objective_with_the_values_inserted(push: PushObjective) -> None:
    held = FixedParameters(push, {"mu": 0.35})
    masses = np.array([[0.6], [1.0], [1.4]])
    full = np.column_stack([masses[:, 0], np.full(3, 0.35)])
    for m, theta in zip(masses, full, strict=True):
        assert held(m) == push(theta)
        np.testing.assert_array_equal(held.evaluate_parts(m), push.evaluate_parts(theta))
        assert all(np.array_equal(a, b) for a, b in zip(held.residuals(m), push.residuals(theta), strict=True))
    np.testing.assert_array_equal(held.evaluate_batch(masses).errors, push.evaluate_batch(full).errors)
    assert held.segments == push.segments and held.n_observations == push.n_observations
    assert held.noise_var == push.noise_var and held.noise_floor == push.noise_floor


def test_the_t6_error_with_a_held_parameter_is_the_full_error_there() -> None:
    from physics import FlopController, simulate
    from physics.trajectory_objective import TrajectoryObjective

    with TrajectoryObjective(simulate(controller=FlopController(heading=0.0), duration=0.3), windows=2,
                             n_workers=0) as full:
        held = FixedParameters(full, {"rod_length": 1.7, "damping": 210.0})
        free = held.space.nominal
        theta = full.space.replace(rod_length=1.7, damping=210.0)
        assert held(free) == full(theta) and held(free) > full(full.space.nominal)
        assert held.space.dim == 13 and "rod_length" not in held.space.names


def test_the_space_drops_the_fixed_parameters_and_keeps_the_others() -> None:
    t6 = ParameterSpace.t6()
    space = free_space(t6, {"radius": 0.06, "damping": 200.0})
    assert space.names == tuple(n for n in t6.names if n not in ("radius", "damping"))
    assert all(space[n] == t6[n] for n in space.names)
    full = insert_fixed(t6, {"radius": 0.061, "damping": 200.0}, space.sample(3, seed=0))
    assert full.shape == (3, 15) and np.all(full[:, t6.index("radius")] == 0.061)
    with pytest.raises(ParameterError, match=re.escape("must have shape (13,) or (n, 13)")):
        insert_fixed(t6, {"radius": 0.06, "damping": 200.0}, t6.nominal)
    with pytest.raises(MeasurementError, match="unknown parameter"):
        free_space(t6, {"radious": 0.06})


def test_full_and_free_are_inverse(push: PushObjective) -> None:
    held = FixedParameters(push, {"m": 1.2})
    assert held.space.names == ("mu",) and held.full_space is push.space
    np.testing.assert_array_equal(held.full(np.array([0.3])), [1.2, 0.3])
    np.testing.assert_array_equal(held.free(held.full(np.array([[0.3], [0.5]]))), [[0.3], [0.5]])
    with pytest.raises(ParameterError, match="a full θ has shape"):
        held.free(np.array([0.3]))


def test_the_fingerprint_names_the_fixed_values(push: PushObjective) -> None:
    a, b = FixedParameters(push, {"mu": 0.4}), FixedParameters(push, {"mu": 0.5})
    assert a.fingerprint()["fixed"] == {"mu": 0.4} and a.fingerprint()["objective"] == push.fingerprint()
    assert a.fingerprint() != b.fingerprint() and a.fingerprint()["parameters"] == ["m"]


@pytest.mark.parametrize(("fixed", "says"), [
    ({"nu": 0.4}, "fixed nu: only a parameter can be fixed; the parameters are m, mu"),
    ({"mu": 1.5}, "fixed mu=1.5 lies outside the range 0.1-1 that the prior box allows"),
    ({"m": -1.0}, "fixed m=-1 kg is impossible: it must be > 0 kg"),
    ({"m": 1.0, "mu": 0.4}, "every parameter of the space is fixed (m, mu): nothing is left to identify"),
])
def test_bad_fixed_values_are_refused(push: PushObjective, fixed: dict[str, float], says: str) -> None:
    with pytest.raises(MeasurementError, match=re.escape(says)):
        FixedParameters(push, fixed)


class _Closing(FunctionObjective):
    closed = 0

    def close(self) -> None:
        self.closed += 1


def test_close_and_the_context_manager_reach_the_wrapped_objective() -> None:
    inner = _Closing(lambda th: float(th.sum()), push_space())
    with FixedParameters(inner, {"mu": 0.4}) as held:
        assert isinstance(held, Objective) and held(np.array([1.0])) == pytest.approx(1.4)
    assert inner.closed == 1
    FixedParameters(FunctionObjective(lambda th: 0.0, push_space()), {"mu": 0.4}).close()   # nothing to close
    assert "mu=0.4" in repr(held)
