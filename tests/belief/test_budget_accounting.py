"""A preset's budget counts every evaluation of E the run makes: the search's, the σ² rule's residuals,
the verdicts' Gauss-Newton step and the finishing step (belief.presets, belief.assess); the result
reports the total, and the budget warnings suggest budgets that, followed, silence them."""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from linear_objective import LinearObjective

from belief import BudgetWarning
from belief.least_squares import gauss_newton_step
from belief.posterior import PosteriorConfig
from belief.presets import run_preset
from belief.verdicts import VerdictConfig
from embeddings import REMBO
from physics.objective import BatchResult, OnResult


def _linear(dim: int, seed: int = 0) -> LinearObjective:
    """E(θ) = ||y − Aθ||² in two segments, σ² unknown (the "ess" rule evaluates the residuals at the
    best θ): a cheap objective with residual vectors, so every Gauss-Newton step runs."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(60, dim))
    return LinearObjective(A, A @ rng.uniform(0.3, 0.7, dim) + 0.01 * rng.normal(size=60), segments=2)


class Counting:
    """``inner``'s objective contract, counting every θ it is asked to evaluate, by any method."""

    def __init__(self, inner: LinearObjective) -> None:
        self.inner, self.space, self.evaluations = inner, inner.space, 0

    segments = property(lambda self: self.inner.segments)
    n_observations = property(lambda self: self.inner.n_observations)
    noise_var = property(lambda self: self.inner.noise_var)
    noise_floor = property(lambda self: self.inner.noise_floor)

    def __call__(self, theta: np.ndarray) -> float:
        self.evaluations += 1
        return self.inner(theta)

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        self.evaluations += 1
        return self.inner.evaluate_parts(theta)

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: OnResult | None = None) -> BatchResult:
        self.evaluations += len(np.atleast_2d(thetas))
        return self.inner.evaluate_batch(thetas, on_result=on_result)

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        self.evaluations += 1
        return self.inner.residuals(theta)

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        self.evaluations += len(np.atleast_2d(thetas))
        return self.inner.residuals_batch(thetas)

    def fingerprint(self) -> dict[str, object]:
        return self.inner.fingerprint()


def _run(preset: str, budget: int, **options):
    """(result, evaluations counted, BudgetWarning messages) of ``preset`` on the 3-D linear objective."""
    objective = Counting(_linear(3))
    decoder = REMBO(objective.space, dim=2, seed=0) if preset.startswith("handoff") else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run_preset(objective, preset, budget=budget, seed=0, decoder=decoder, progress=False, **options)
    return result, objective.evaluations, [str(w.message) for w in caught if issubclass(w.category, BudgetWarning)]


@pytest.mark.parametrize("refit", [True, False], ids=["verdicts-step-shared", "step-taken-for-the-finish"])
def test_the_default_preset_makes_exactly_its_budget_of_evaluations_and_reports_them(refit: bool) -> None:
    """Step 6 of belief.assess (the verdicts' Gauss-Newton step, D + 4) and the σ² residuals used to come
    on top of the budget; now the finishing step is that step and starts from those residuals."""
    result, counted, _ = _run("handoff-gn", 40, verdict_config=VerdictConfig(refit=refit))
    local = result.belief.attrs["local_fit"]
    assert ("error" in local) == refit                   # the verdicts' step ran, or was not needed
    assert result.config["stages"][0].startswith("latent (REMBO, 15 evaluations)")
    assert counted == 40
    assert result.config["evaluations"] == {"search": 40 - 7, "after_search": 7, "total": 40}
    assert "after 40 evaluations of E (budget 40): 33 by the search and 7 after it" in result.summary()
    assert result.config["local_step"]["error"] <= result.config["local_step"]["start_error"]


@pytest.mark.parametrize("posterior", ["minimizer", PosteriorConfig(noise_rule="iid"), PosteriorConfig(noise_var=1e-4),
                                       None, PosteriorConfig(noise_rule="calibrated")],
                         ids=["minimizer", "iid", "known-noise", "no-posterior", "calibrated"])
def test_every_posterior_keeps_a_finishing_step_preset_within_its_budget(posterior) -> None:
    budget = 60                     # the calibrated rule keeps a fit's 5 x (3 + 4) + 3 = 38 for its fit
    result, counted, _ = _run("bo-gn", budget, posterior=posterior)
    assert counted <= budget and result.config["evaluations"]["total"] == counted
    assert result.config["local_step"]["evaluations"] > 0


def test_a_preset_without_the_step_keeps_its_assessment_within_its_budget() -> None:
    """``bo`` keeps the verdicts' step's D + 4 = 7 of its budget for the assessment, as bo-gn for its step
    (belief.presets.reserved_evaluations), and takes the step only when a parameter narrowed: here p1
    and p2 are identified, so the σ² residuals and the step spend all 7 and the run makes exactly 30."""
    result, counted, _ = _run("bo", 30)
    assert "error" in result.belief.attrs["local_fit"]              # the verdicts' step ran
    assert result.n_evaluations == 30 - 7 and counted == result.config["evaluations"]["total"] == 30
    assert result.config["evaluations"] == {"search": 23, "after_search": 7, "total": 30}
    text = result.summary()
    assert "after 30 evaluations of E (budget 30): 23 by the search and 7 after it" in text
    assert "which counts the search's" not in text


def _suggested(messages: list[str], pattern: str) -> int:
    found = [int(m.group(1)) for m in (re.search(pattern, text) for text in messages) if m]
    assert found, f"no budget suggested in {messages}"
    return found[0]


def test_the_gp_warning_counts_the_search_and_its_suggested_budget_silences_it() -> None:
    """30 = 10 per dimension of D = 3: with the finishing step's 7 the warning must ask for 37."""
    result, _, messages = _run("handoff-gn", 30)
    assert "23 successful evaluations for a 3-dimensional search" in result.belief.attrs["budget_warning"]
    suggested = _suggested(messages, r"give a budget of (\d+) evaluations of E")
    assert suggested == 30 + 7
    again, _, messages = _run("handoff-gn", suggested)
    assert again.belief.attrs["budget_warning"] == "" and not any("per dimension" in m for m in messages)


def test_the_initial_design_warning_suggests_a_budget_that_lets_bo_run() -> None:
    """bo-gn in D = 3: 7 for the step and an initial design of 5 cells; a budget of 12 leaves BO nothing."""
    _, _, messages = _run("bo-gn", 12)
    suggested = _suggested(messages, r"BO never runs.*give budget >= (\d+)")
    assert suggested == 13
    _, _, messages = _run("bo-gn", suggested)
    assert not any("BO never runs" in m for m in messages)


def test_a_step_from_residuals_already_evaluated_costs_one_evaluation_less_and_lands_alike() -> None:
    objective = Counting(_linear(3))
    theta = np.array([0.2, 0.8, 0.5])
    fresh = gauss_newton_step(objective, theta)
    assert objective.evaluations == fresh.evaluations == 3 + 4
    shared = gauss_newton_step(objective, theta, start=objective.inner.residuals(theta))
    assert shared.evaluations == 3 + 3 and objective.evaluations == 7 + 6
    np.testing.assert_array_equal(shared.theta, fresh.theta)
    assert shared.error == fresh.error
