"""Bounded least-squares refinement (belief.least_squares) on problems whose answer is known."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares as scipy_least_squares
from scipy.optimize import lsq_linear

from belief.errors import BeliefError
from belief.least_squares import LeastSquaresConfig, StepConfig, gauss_newton_step, refine
from physics import ParameterSpace, PushObjective, generate_push_data, push_space
from physics.parameters import Parameter


class Linear:
    """r(θ) = y - A θ split into two segments: the minimum of ||r||² in the box is lsq_linear's."""

    def __init__(self, A, y, lower, upper):
        self.A, self.y = A, y
        self.space = ParameterSpace(tuple(Parameter(f"p{j}", "1", 0.5 * (lo + hi), lo, hi, "", minimum=-np.inf)
                                          for j, (lo, hi) in enumerate(zip(lower, upper))))
        self.segments = ("w0", "w1")

    def residuals(self, theta):
        r = self.y - self.A @ np.asarray(theta, float)
        half = len(r) // 2
        return [r[:half, None], r[half:, None]]

    def residuals_batch(self, thetas):
        return [self.residuals(t) for t in np.atleast_2d(thetas)]


def _problem(seed, inside=True):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(40, 4)) @ np.diag([1.0, 3.0, 0.3, 1.0])
    truth = rng.uniform(0.2, 0.8, 4) if inside else np.array([0.5, 1.4, -0.3, 0.5])
    y = A @ truth + 0.01 * rng.normal(size=40)
    return Linear(A, y, np.zeros(4), np.ones(4)), truth


@pytest.mark.parametrize("seed", range(3))
def test_refine_reaches_the_least_squares_solution_in_the_box(seed):
    objective, _ = _problem(seed, inside=seed != 2)
    exact = lsq_linear(objective.A, objective.y, bounds=(0.0, 1.0))
    result = refine(objective, np.full(4, 0.5), range(4), [True, True], LeastSquaresConfig(evaluations=20))
    assert result.error == pytest.approx(2 * exact.cost, rel=1e-3, abs=1e-9)
    assert np.allclose(result.theta, exact.x, atol=2e-3)
    assert result.parts.sum() == pytest.approx(result.error)
    assert (result.theta >= 0).all() and (result.theta <= 1).all()


def test_refine_moves_only_the_given_parameters_and_fits_only_the_masked_segments():
    objective, truth = _problem(5)
    start = np.full(4, 0.5)
    result = refine(objective, start, [1, 3], [True, False])
    assert result.theta[[0, 2]].tolist() == [0.5, 0.5]
    half = objective.A[:20]
    exact = lsq_linear(half[:, [1, 3]], objective.y[:20] - half[:, [0, 2]] @ start[[0, 2]], bounds=(0.0, 1.0))
    assert result.error == pytest.approx(2 * exact.cost, rel=1e-3)
    assert result.error == pytest.approx(result.parts[0]) and result.error <= result.start_error


def test_refine_never_rises_and_steps_away_from_divergence():
    space = push_space()
    J, S = generate_push_data([1.2, 0.5], n=8, noise_std=0.001, seed=1)
    objective = PushObjective(J, S, space=space, fail_above=1.3, windows=2)
    # with mu held at 0.2 the best mass is 1.2 sqrt(0.5 / 0.2) = 1.9 kg, but above 1.3 kg the toy "diverges"
    result = refine(objective, np.array([1.0, 0.2]), [0], [True, True])
    assert result.error < result.start_error and 1.2 < result.theta[0] <= 1.3
    held = refine(objective, np.array([1.0, 0.5]), [0], [True, True])
    assert held.theta[0] == pytest.approx(1.2, rel=0.01)


class Valley(Linear):
    """Rosenbrock's valley as residuals r = (10 (θ1 - θ0²), 1 - θ0) in [-2, 2]²: minimum 0 at (1, 1),
    reached along a curved ridge that a few trust-region steps do not follow to its end."""

    def __init__(self):
        super().__init__(np.zeros((2, 2)), np.zeros(2), [-2.0, -2.0], [2.0, 2.0])

    def residuals(self, theta):
        x, y = np.asarray(theta, float)
        return [np.array([[10.0 * (y - x * x)]]), np.array([[1.0 - x]])]


def test_further_rounds_go_on_from_the_best_point_and_stop_once_a_round_gains_little():
    objective, start = Valley(), np.array([-1.2, 1.0])
    one = refine(objective, start, range(2), [True, True], LeastSquaresConfig(evaluations=4))
    again = refine(objective, one.theta, range(2), [True, True], LeastSquaresConfig(evaluations=4))
    two = refine(objective, start, range(2), [True, True], LeastSquaresConfig(evaluations=4, rounds=2, converged=0.0))
    assert two.error == pytest.approx(again.error, rel=1e-9) and two.error < one.error
    many = refine(objective, start, range(2), [True, True], LeastSquaresConfig(evaluations=4, rounds=40))
    assert many.error < 1e-3 * one.error and np.allclose(many.theta, 1.0, atol=0.05)
    linear, _ = _problem(0)
    settled = [refine(linear, np.full(4, 0.5), range(4), [True, True], LeastSquaresConfig(evaluations=20, rounds=r))
               for r in (2, 6)]
    assert settled[0].evaluations == settled[1].evaluations     # the second round gains nothing: no third


def test_patience_runs_on_after_a_stalled_run_and_stops_after_that_many_in_a_row(monkeypatch):
    import belief.least_squares as module
    calls = []

    def counted(*args, **kwargs):
        calls.append(1)
        return scipy_least_squares(*args, **kwargs)

    monkeypatch.setattr(module, "scipy_least_squares", counted)
    linear, _ = _problem(0)
    runs = {}
    for patience, rounds in ((1, 6), (2, 2), (2, 6), (3, 6)):
        calls.clear()
        refine(linear, np.full(4, 0.5), range(4), [True, True],
               LeastSquaresConfig(evaluations=20, rounds=rounds, patience=patience))
        runs[patience, rounds] = len(calls)
    # the first run solves the linear problem; each later one stalls
    assert runs == {(1, 6): 2, (2, 2): 2, (2, 6): 3, (3, 6): 4}, runs
    with pytest.raises(BeliefError, match="patience"):
        LeastSquaresConfig(rounds=3, patience=0)


def test_a_journal_records_the_rounds_only_when_there_are_several():
    assert set(LeastSquaresConfig().record()) == {"evaluations", "step", "tolerance"}
    assert LeastSquaresConfig(rounds=3, converged=0.02).record()["converged"] == 0.02
    assert LeastSquaresConfig(rounds=3).record() != LeastSquaresConfig(rounds=4).record()
    assert LeastSquaresConfig(rounds=3, patience=1).record() == LeastSquaresConfig(rounds=3).record()
    assert LeastSquaresConfig(rounds=3, patience=2).record()["patience"] == 2
    assert "patience" not in LeastSquaresConfig(rounds=1, patience=2).record()


def test_refine_refuses_a_failing_start_and_bad_settings():
    J, S = generate_push_data([1.0, 0.5], n=6)
    objective = PushObjective(J, S, fail_above=1.3)
    with pytest.raises(BeliefError, match="diverged"):
        refine(objective, np.array([1.4, 0.5]), [0, 1], [True, True])
    with pytest.raises(BeliefError, match="mask"):
        refine(objective, np.array([1.0, 0.5]), [0], [False, False])
    with pytest.raises(BeliefError, match="evaluations"):
        LeastSquaresConfig(evaluations=0)
    with pytest.raises(BeliefError, match="rounds"):
        LeastSquaresConfig(rounds=0)


def test_one_gauss_newton_step_solves_a_linear_problem_and_gives_its_laplace_std():
    """r linear in θ: one undamped step (radius 1) lands on lsq_linear's solution, and the local std is
    sqrt diag (AᵀA/σ²)⁻¹ (unit box = θ box here); a column that another reproduces has no bound."""
    objective, _ = _problem(1)
    exact = lsq_linear(objective.A, objective.y, bounds=(0.0, 1.0))
    step = gauss_newton_step(objective, np.full(4, 0.5), StepConfig(radius=1.0, ridge=0.0))
    assert step.error == pytest.approx(2 * exact.cost, rel=1e-6)
    assert np.allclose(step.theta, exact.x, atol=1e-6)
    assert step.evaluations == 4 + 1 + 3 and step.start_error > step.error
    sigma2 = 0.01 ** 2
    expected = np.sqrt(np.diag(np.linalg.inv(objective.A.T @ objective.A / sigma2)))
    assert np.allclose(step.laplace_std(sigma2), expected, rtol=1e-5)
    objective.A[:, 3] = 2.0 * objective.A[:, 2]
    std = gauss_newton_step(objective, np.full(4, 0.5)).laplace_std(sigma2)
    assert std[2] > 10 and std[3] > 10 and std[0] < 1


def test_a_short_trust_radius_keeps_the_step_inside_it_and_never_worsens_e():
    objective, _ = _problem(2, inside=False)
    start = np.full(4, 0.5)
    step = gauss_newton_step(objective, start, StepConfig(radius=0.05))
    assert np.all(np.abs(step.theta - start) <= 0.05 + 1e-12) and step.error <= step.start_error
    with pytest.raises(BeliefError, match="StepConfig"):
        StepConfig(radius=0.0)
