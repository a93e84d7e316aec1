"""The test of a parameter at a bound (criticism.wider_box): re-fitted in a wider box, it moves out and
the error drops (the box is too narrow), or it stands in for what the model lacks (compensation); and
diagnose's report says per parameter what was tested (issue 65, item 3)."""
from __future__ import annotations

import importlib
import json
from types import SimpleNamespace

import numpy as np
import pytest
from linear_objective import LinearObjective

from belief import Belief, SobolCandidates, at_bounds
from belief.html_report import Page
from belief.least_squares import LeastSquaresConfig, refine
from criticism import (
    Candidate,
    Criticism,
    CriticismError,
    DiagnoseConfig,
    Diagnosis,
    diagnosis_record,
    diagnosis_text,
)
from criticism.html_report import _pass
from criticism.wider_box import (
    COMPENSATION,
    TOO_NARROW,
    WiderBoxConfig,
    check_wider_box,
    retuned_at_bounds,
    widened_space,
)
from embeddings import Identity
from physics import ParameterSpace
from physics.parameters import Parameter

T6 = ParameterSpace.t6()
diagnose_module = importlib.import_module("criticism.diagnose")   # the package exports a function of that name
RNG = np.random.default_rng(3)
A = RNG.normal(size=(90, 3))
ALL = np.ones(3, bool)


def _orthogonal(size: float) -> np.ndarray:
    """A residual of norm ``size`` that no θ of the model A θ can produce (orthogonal to A's columns)."""
    w = RNG.normal(size=A.shape[0])
    w -= A @ np.linalg.lstsq(A, w, rcond=None)[0]
    return size * w / np.linalg.norm(w)


def _fitted(objective: LinearObjective) -> np.ndarray:
    """The bounded least-squares fit in the unit box (the re-tuning's stand-in), converged."""
    return refine(objective, np.full(3, 0.5), range(3), ALL, LeastSquaresConfig(evaluations=40)).theta


def test_a_minimum_outside_the_box_is_found_and_called_too_narrow() -> None:
    y = A @ np.array([1.4, 0.3, 0.6]) + _orthogonal(0.05)
    objective = LinearObjective(A, y, segments=3)
    theta = _fitted(objective)
    entries = at_bounds(objective.space, theta, source="re-tuning")
    assert [(e.name, e.side) for e in entries] == [("p0", "upper")]
    check = check_wider_box(objective, theta, entries, ALL)
    assert check is not None
    (outcome,) = check.outcomes
    free = np.linalg.lstsq(A, y, rcond=None)[0]                 # the unbounded minimum
    assert outcome.widened == 2.0 and outcome.verdict == TOO_NARROW
    assert outcome.value == pytest.approx(free[0], abs=0.02) and outcome.beyond > 0.3
    assert outcome.change < -0.5
    assert 0 < check.evaluations <= WiderBoxConfig().cost(3, pinned=1)
    text = outcome.advice(flag=True)
    assert f"moved it to {outcome.value:.4g}" in text and "the box is too narrow: widen it (--bounds p0=0:2)" in text


def _compensating() -> LinearObjective:
    """p0's truth 0.98 lies inside its box, but an effect the model lacks (a large residual no θ fits,
    and a small part along p0's column) pulls the fit to 1.05: out of the box, for a tiny gain."""
    y = A @ np.array([0.98, 0.3, 0.6]) + _orthogonal(5.0) + 0.07 * A[:, 0]
    return LinearObjective(A, y, segments=3)


def test_a_parameter_standing_in_for_a_missing_term_is_compensation() -> None:
    objective = _compensating()
    theta = _fitted(objective)
    entries = at_bounds(objective.space, theta, source="re-tuning")
    assert [(e.name, e.side) for e in entries] == [("p0", "upper")]
    (outcome,) = check_wider_box(objective, theta, entries, ALL).outcomes
    assert outcome.beyond > 0.01 and outcome.value < 1.1           # given room, it moves a little
    assert -0.01 < outcome.change < 0                               # for less than 1 % of the error
    assert outcome.verdict == COMPENSATION
    assert "compensation for a missing effect or an engine mismatch" in outcome.advice()
    assert "too narrow" not in outcome.advice()


def test_with_the_likelihoods_variance_the_drop_is_counted_in_nats() -> None:
    """The same gain is significant against a small σ² (many nats) and not against a large one."""
    objective = _compensating()
    theta = _fitted(objective)
    entries = at_bounds(objective.space, theta)
    drop = objective(theta) - objective(np.linalg.lstsq(A, objective.y, rcond=None)[0])
    sharp = check_wider_box(objective, theta, entries, ALL, noise_var=drop / 20).outcomes[0]
    broad = check_wider_box(objective, theta, entries, ALL, noise_var=drop).outcomes[0]
    assert sharp.verdict == TOO_NARROW and "nats" in sharp.advice()
    assert broad.verdict == COMPENSATION and broad.needed == pytest.approx(2 * drop)


def test_each_parameter_is_credited_only_with_what_its_own_room_buys() -> None:
    """p2's truth lies outside the box; p0's inside, but a term the model lacks pulls it out, and p1,
    nearly collinear with it, can make up for it. The whole re-fit's drop is p2's, and p0 put back on
    its bound with p1 held would look costly: neither may call p0's box too narrow."""
    rng = np.random.default_rng(11)
    c0, c2 = rng.normal(size=90), rng.normal(size=90)
    a = np.stack([c0, c0 + 0.05 * rng.normal(size=90), c2], axis=1)
    w = rng.normal(size=90)
    w -= a @ np.linalg.lstsq(a, w, rcond=None)[0]
    objective = LinearObjective(a, a @ np.array([0.98, 0.97, 1.5]) + 5.0 * w / np.linalg.norm(w) + 0.15 * c0,
                                segments=3)
    theta = _fitted(objective)
    entries = at_bounds(objective.space, theta)
    check = check_wider_box(objective, theta, entries, ALL)
    found = {o.name: o for o in check.outcomes}
    p0 = found["p0"]
    held = np.array(check.theta)
    held[0] = p0.bound
    assert p0.beyond > 0.05 and objective(held) - p0.error_after > p0.needed        # held: it would count
    assert p0.error_before - p0.error_after > p0.needed                              # so would the whole drop
    assert p0.gain < p0.needed and p0.verdict == COMPENSATION
    assert found["p2"].verdict == TOO_NARROW and found["p2"].value == pytest.approx(1.5, abs=0.02)


def test_a_lower_bound_stops_short_of_the_physical_limit() -> None:
    space = ParameterSpace((Parameter("mass", "kg", 1.0, 0.5, 1.5),
                            Parameter("drag", "N*s/m", 1.0, 0.0, 2.0, strict=False)))
    entries = at_bounds(space, np.array([0.5, 0.0]))
    wide = widened_space(space, entries, WiderBoxConfig())
    assert wide["mass"].lower == pytest.approx(0.05) and wide["mass"].upper == 1.5    # 10 % of the way to 0
    assert (wide["drag"].lower, wide["drag"].upper) == (0.0, 2.0)                  # 0 is drag's limit
    assert widened_space(space, entries, WiderBoxConfig(widen=0.3))["mass"].lower == pytest.approx(0.2)
    with pytest.raises(CriticismError, match="widen > 0"):
        WiderBoxConfig(widen=0.0)


class _T6Linear(LinearObjective):
    """A linear objective over the T6 box: the prediction is A u(θ), u the unit-box coordinates."""

    def __init__(self, A: np.ndarray, y: np.ndarray) -> None:
        super().__init__(A, y, segments=3)
        self.space = T6

    def mean(self, theta: np.ndarray) -> np.ndarray:
        return self.A @ ((np.asarray(theta, float) - T6.lower) / (T6.upper - T6.lower))

    effects = ()


def _t6_case() -> tuple[_T6Linear, np.ndarray]:
    """maxTens's truth beyond its upper bound; density's part of a term the model lacks pulls it below
    its lower one; the identification's θ̂ at the box centre."""
    a = np.random.default_rng(5).normal(size=(150, T6.dim))
    u = np.full(T6.dim, 0.5)
    u[T6.index("maxTens")] = 1.4
    u[T6.index("density")] = 0.02
    w = np.zeros(150)                              # orthogonal to the model on the fit segments (rows 0-99)
    w[:100] = np.random.default_rng(6).normal(size=100)
    w[:100] -= a[:100] @ np.linalg.lstsq(a[:100], w[:100], rcond=None)[0]
    y = a @ u + 8.0 * w / np.linalg.norm(w) - 0.08 * a[:, T6.index("density")]
    return _T6Linear(a, y), T6.lower + 0.5 * (T6.upper - T6.lower)


def _belief() -> Belief:
    dec = Identity(T6)
    grid = SobolCandidates.for_decoder(dec, n=64, seed=0)
    return Belief.from_posterior(grid.to_dataarray(np.full(grid.size, 1.0 / grid.size)), dec, grid)


def test_diagnose_tests_each_pinned_parameter_and_the_report_says_what_was_tested(monkeypatch) -> None:
    """diagnose's pass (its criticism replaced by a converged least-squares re-tuning) tests the
    parameters left at a bound, and report.txt, diagnosis.json and report.html say per parameter
    what the wider box did and the verdict."""
    objective, start = _t6_case()
    fit, held = np.array([True, True, False]), np.array([False, False, True])
    floor = Candidate("re-tuned model", "floor", {}, 1.0, 2.0, 0.1, 3.0)

    def retune(model, theta, **kwargs):
        tuned = refine(model, theta, range(T6.dim), fit, LeastSquaresConfig(evaluations=60, rounds=3)).theta
        return Criticism(tuned, 1.0, 2.0, 10.0, 10.0, [], floor, "unexplained", None)

    monkeypatch.setattr(diagnose_module, "criticize", retune)
    monkeypatch.setattr(diagnose_module, "residual_summary", lambda ds: {})
    monkeypatch.setattr(diagnose_module, "residual_dataset", lambda model, theta: None)
    ident = SimpleNamespace(best_theta=start, belief=_belief())
    step = diagnose_module._criticize(objective, ident, [], (fit, held), config=DiagnoseConfig(), progress=False)
    assert {(a.name, a.side) for a in step.at_bounds} == {("maxTens", "upper"), ("density", "lower")}
    verdicts = {o.name: o for o in step.wider_box.outcomes}
    assert verdicts["maxTens"].verdict == TOO_NARROW and verdicts["density"].verdict == COMPENSATION
    d = Diagnosis([step], (), [2], None, {"bound_tolerance": 0.01})
    text = diagnosis_text(d)
    mt = verdicts["maxTens"]
    assert (f"re-fitting with the box widened to {mt.widened:.4g} N moved it to {mt.value:.4g} N" in text
            and f"the box is too narrow: widen it (--bounds maxTens={mt.other:.4g}:{mt.widened:.4g})" in text)
    assert f"the box widened to {verdicts['density'].widened:.4g} kg/m^3" in text
    assert "compensation for a missing effect or an engine mismatch" in text
    assert f"({step.wider_box.evaluations} evaluations of E;" in text and "or the box is too narrow" not in text
    record = json.loads(json.dumps(diagnosis_record(d), default=float))["passes"][0]["wider_box"]
    assert {o["name"]: o["verdict"] for o in record["outcomes"]} == {"maxTens": TOO_NARROW, "density": COMPENSATION}
    page = Page("t")
    _pass(page, 1, step, d)
    assert "the box is too narrow: widen it" in page.render()


def test_without_the_test_the_block_says_it_was_not_tested() -> None:
    theta = T6.lower + 0.5 * (T6.upper - T6.lower)
    theta[T6.index("damping")] = T6.lower[T6.index("damping")]
    pinned = retuned_at_bounds(T6, T6.lower + 0.5 * (T6.upper - T6.lower), theta, None)
    floor = Candidate("re-tuned model", "floor", {}, 1.0, 2.0, 0.1, 3.0)
    step = diagnose_module.Pass((), T6.names, theta, Criticism(theta, 1.0, 2.0, 10.0, 10.0, [], floor,
                                                               "unexplained", None), {"t1": 2.0}, at_bounds=pinned)
    text = diagnosis_text(Diagnosis([step], (), [1], None, {"bound_tolerance": 0.01}))
    assert "damping at lower bound 180" in text and "Not tested in a wider box" in text


@pytest.mark.slow
def test_diagnose_on_flops_tells_the_one_box_too_narrow_from_the_parameters_standing_in_for_it() -> None:
    """The user's case, small: flops of 1.74 m rods identified in a box whose rod_length stops at 1.65 m.
    The re-tuning pins many parameters; only rod_length's box is called too narrow, and the wider box
    finds its value."""
    from physics import FlopController, simulate
    theta = T6.nominal
    flops = [simulate(theta, controller=FlopController(heading=h), duration=0.3) for h in (0.0, 1.5708)]
    space = ParameterSpace.t6(bounds={"rod_length": (1.5, 1.65)})
    config = DiagnoseConfig(passes=1, budget=6, candidates=32, horizon=5, mismatch=None, measure_at_rest=False)
    with pytest.warns(Warning):                  # the budget is far below what the GP needs (a BudgetWarning)
        result = diagnose_module.diagnose(flops, effects=[], config=config, n_workers=0, progress=False, space=space)
    step = result.passes[0]
    verdicts = {o.name: o for o in step.wider_box.outcomes}
    assert [a.name for a in step.at_bounds] == list(verdicts) and len(verdicts) > 1
    assert [n for n, o in verdicts.items() if o.verdict == TOO_NARROW] == ["rod_length"]
    assert verdicts["rod_length"].value == pytest.approx(theta[T6.index("rod_length")], abs=0.01)
    assert step.wider_box.evaluations <= DiagnoseConfig().wider_box.cost(T6.dim, pinned=len(verdicts))
    assert "the box is too narrow: widen it (--bounds rod_length=1.5:1.8)" in diagnosis_text(result)
