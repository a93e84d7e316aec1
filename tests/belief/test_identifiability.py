"""The identifiability map (belief.identifiability) on Jacobians whose answer is known: repeated
columns leave their difference free, a zero column is inert, rows orthogonal to the mass–force
direction leave that symmetry exact and a measurement row along it resolves it, widths are
1/√λ of the information in relative units; and on the T6's own Jacobian of a short flop, where
the symmetry of physics.scaling is exact."""
from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import BeliefError, Identifiability, identifiability
from belief.identifiability import MASS_FORCE, Direction
from physics.parameters import Parameter, ParameterSpace

#: two parameters with a mass in their unit, two without, one whose nominal is 0 (an effect that is off)
SPACE = ParameterSpace((Parameter("mass", "kg", 2.0, 1.8, 2.2), Parameter("stiffness", "N/m", 100.0, 90.0, 110.0),
                        Parameter("length", "m", 1.0, 0.9, 1.1), Parameter("angle", "rad", 1.0, 0.9, 1.1),
                        Parameter("offset", "m", 0.0, -0.1, 0.1, minimum=-1.0)))
THETA, WIDTH = SPACE.nominal, SPACE.upper - SPACE.lower
SCALE = np.where(THETA != 0, np.abs(THETA), WIDTH)
T = SCALE / WIDTH                                     # du = T dx (x: relative changes)
P_HAT = np.array([1.0, 1.0, 0.0, 0.0, 0.0]) / np.sqrt(2.0)
SIGMA2 = 1e-4


def _map(jac_x: np.ndarray, prior_x: np.ndarray | None = None) -> Identifiability:
    """The map of a Jacobian (and prior rows) written in relative units x, turned into the unit box."""
    prior = None if prior_x is None else prior_x / T
    return identifiability(jac_x / T, noise_var=SIGMA2, space=SPACE, theta=THETA, width=WIDTH, prior_rows=prior)


def _random(seed: int, rows: int = 40) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(rows, SPACE.dim))


def test_widths_are_one_over_root_information_and_classified() -> None:
    a = np.array([1.0, 0.2, 0.02, 0.005, 0.8])                  # sensitivities per relative change
    m = _map(np.diag(a))
    width = 100.0 * np.sqrt(SIGMA2) / a                              # hand computed 1/√λ, in %
    order = np.argsort(width)
    assert [v.width_pct for v in m.directions] == pytest.approx(width[order], rel=1e-12)
    assert [v.text for v in m.directions] == [f"+1.00 {SPACE.names[j]}" for j in order]
    assert [v.kind for v in m.directions] == ["pinned", "pinned", "weak", "free", "free"]
    assert [v.box_pct for v in m.directions] == pytest.approx([10.0, 50.0, 10.0, 10.0, 10.0])   # offset: its box
    marginal = 100.0 * np.sqrt(SIGMA2) / a * SCALE / np.where(SPACE.nominal != 0, SPACE.nominal, WIDTH)
    assert m.marginal_pct == pytest.approx(marginal, rel=1e-6)
    assert m.inert == ()


def test_two_identical_columns_leave_their_difference_free_and_named() -> None:
    J = _random(0)
    J[:, 3] = J[:, 2]
    m = _map(J)
    last = m.directions[-1]
    assert last.kind == "free" and last.width_pct > 1e6
    assert last.text == "+0.71 length −0.71 angle" or last.text == "+0.71 angle −0.71 length"
    assert m.count("free") == 1 and m.inert == ()


def test_a_zero_column_is_inert_and_free() -> None:
    J = _random(1)
    J[:, 1] = 0.0
    m = _map(J)
    assert m.inert == ("stiffness",)
    assert m.directions[-1].text == "+1.00 stiffness" and m.directions[-1].width_pct == np.inf
    assert "inert (these motions do not move it): stiffness" in m.lines()


def test_rows_orthogonal_to_the_mass_force_direction_make_it_an_exact_symmetry() -> None:
    J = _random(2)
    J -= np.outer(J @ P_HAT, P_HAT)
    m = _map(J)
    (sym,) = m.symmetries
    assert sym.name == MASS_FORCE and sym.status == "exact" and sym.share < 1e-12
    assert sym.loadings == pytest.approx(P_HAT)
    assert m.directions[-1].label == "the mass–force scale" and m.directions[-1].kind == "free"
    assert any(line.startswith(f"symmetry: {MASS_FORCE} is exact") for line in m.lines())
    weighed = _map(J, prior_x=P_HAT[None] / 0.05)                 # a measurement of the scale to 5 %
    (sym,) = weighed.symmetries
    assert sym.status == "resolved" and sym.width_pct == pytest.approx(5.0)
    assert any(line.startswith(f"symmetry: {MASS_FORCE} is resolved: pinned to ±5") for line in weighed.lines())


def test_a_faint_view_of_the_symmetry_is_near() -> None:
    J = _random(3)
    J -= np.outer(J @ P_HAT, P_HAT)
    J += 1e-3 * np.outer(np.ones(len(J)), P_HAT) * np.linalg.norm(J) / np.sqrt(len(J))
    (sym,) = _map(J).symmetries
    assert sym.share > 1e-6 and sym.width_pct > sym.box_pct and sym.status == "near"


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), factor=st.floats(0.01, 100.0))
def test_directions_are_orthonormal_and_widths_scale_with_the_noise(seed: int, factor: float) -> None:
    J = _random(seed, rows=12)
    base = _map(J)
    V = np.array([v.loadings for v in base.directions])
    assert V @ V.T == pytest.approx(np.eye(SPACE.dim), abs=1e-10)
    widths = np.array([v.width_pct for v in base.directions])
    assert np.all(np.diff(widths) >= 0)                                  # best pinned first
    noisier = identifiability(J / T, noise_var=SIGMA2 * factor, space=SPACE, theta=THETA, width=WIDTH)
    assert [v.width_pct for v in noisier.directions] == pytest.approx(widths * np.sqrt(factor), rel=1e-6)


def test_the_map_round_trips_through_json() -> None:
    J = _random(4)
    J[:, 1] = 0.0
    m = _map(J)
    back = Identifiability.from_dict(json.loads(json.dumps(m.as_dict(), allow_nan=False)))
    assert back == m
    assert back.lines() == m.lines()


def test_bad_inputs_are_refused_by_name() -> None:
    J = _random(5)
    good = {"noise_var": SIGMA2, "space": SPACE, "theta": THETA, "width": WIDTH}
    cases = [("jacobian", {"jacobian": J[:, :3]}), ("prior_rows", {"prior_rows": np.ones((1, 2))}),
             ("theta", {"theta": THETA[:2]}), ("width", {"width": -WIDTH}), ("noise_var", {"noise_var": 0.0}),
             ("pinned_pct", {"pinned_pct": -1.0}), ("jacobian", {"jacobian": np.full_like(J, np.nan)})]
    for name, change in cases:
        args = {"jacobian": J, **good, **change}
        with pytest.raises(BeliefError, match=name):
            identifiability(args.pop("jacobian"), **args)
    with pytest.raises(BeliefError, match="names"):
        Identifiability.from_dict({"directions": [], "symmetries": []})
    with pytest.raises(BeliefError, match="kind"):
        Direction(information=1.0, width_pct=1.0, box_pct=10.0, loadings=(1.0,), text="", kind="loose")  # type: ignore[arg-type]
    record = _map(J).as_dict()
    record["marginal_pct"] = [1.0]
    with pytest.raises(BeliefError, match="one per name"):
        Identifiability.from_dict(record)


@pytest.mark.slow
def test_the_t6_flop_leaves_the_mass_force_scale_exact() -> None:
    """The bare T6's Jacobian of a 1-s noise-free flop (one-step errors; forward differences with a
    small step, since their truncation error, O(h), is all an exact symmetry leaves in J)."""
    from belief import StepConfig, gauss_newton_step
    from physics import FlopController, TrajectoryObjective, simulate

    space = ParameterSpace.t6()
    data = simulate(space.nominal, controller=FlopController(heading=0.0), duration=1.0)
    step = gauss_newton_step(TrajectoryObjective(data, n_workers=0), space.nominal, StepConfig(step=1e-4))
    m = identifiability(step.jacobian, noise_var=(2e-4) ** 2, space=space, theta=space.nominal, width=step.width)
    (sym,) = m.symmetries
    assert sym.status == "exact" and sym.share < 1e-9            # measured: 2e-17
    assert sym.width_pct > 100 * sym.box_pct
    assert m.directions[0].kind == "pinned" and "rod_length" in m.directions[0].text
