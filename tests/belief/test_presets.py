"""belief.presets: named recipes over the one driver, their stages, budgets and finishing step."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from linear_objective import LinearObjective

from belief import BeliefError, BudgetError, Grid, identify
from belief.presets import DEFAULT_PRESET, PRESETS, Preset, PresetWarning, reserved_evaluations, resolve, run_preset
from embeddings import REMBO, Identity
from physics.push import PushObjective, generate_push_data, push_space


@pytest.fixture
def push() -> PushObjective:
    space = push_space()
    impulses, observed = generate_push_data(np.array([1.0, 0.4]), n=8, noise_std=0.05, seed=0)
    return PushObjective(impulses, observed, space=space, noise_std=0.05)


class Counting:
    """The objective contract of ``inner``, counting residual evaluations (the finishing step's)."""

    def __init__(self, inner: PushObjective) -> None:
        self.inner, self.residual_rows = inner, 0

    def residuals_batch(self, thetas: np.ndarray):
        self.residual_rows += len(np.atleast_2d(thetas))
        return self.inner.residuals_batch(thetas)

    def __getattr__(self, name: str):
        return getattr(self.inner, name)

    def __call__(self, theta: np.ndarray) -> float:
        return self.inner(theta)


def test_the_bo_preset_is_full_space_bo_over_the_same_cells(push) -> None:
    """The preset's budget keeps D + 4 = 6 for the assessment; a grid's search budget counts the search's."""
    result = run_preset(push, "bo", budget=12 + 6, seed=3, progress=False)
    decoder = Identity(push.space)
    direct = identify(push, decoder, Grid.for_decoder(decoder, points_per_dim=11), budget=12, seed=3, progress=False)
    assert result.n_evaluations == direct.n_evaluations == 12
    np.testing.assert_array_equal(result.history["theta"].values, direct.history["theta"].values)
    assert result.config["preset"] == "bo" and result.config["stages"] == ["bo over the full space"]


def test_the_finishing_step_counts_in_the_budget_and_never_raises_the_best_error(push) -> None:
    counting = Counting(push)
    bo = run_preset(push, "bo", budget=9 + 2 + 4, seed=1, progress=False)      # the same 9 of search: bo keeps
    assert bo.n_evaluations == 9                                                # the same reserve, unspent
    result = run_preset(counting, "bo-gn", budget=9 + 2 + 4, seed=1, progress=False)
    step = result.config["local_step"]
    assert result.n_evaluations == 9 and step["evaluations"] == push.space.dim + 4
    assert result.best_error <= bo.best_error + 1e-12
    assert step["error"] <= step["start_error"] + 1e-12
    assert counting.residual_rows >= step["evaluations"]
    assert result.config["evaluations"] == {"search": 9, "after_search": 6, "total": 15}
    assert "after 15 evaluations of E (budget 15): 9 by the search and 6 after it" in result.summary()
    assert f"finishing Gauss-Newton step took E {step['start_error']:.6g} -> {step['error']:.6g}" in result.summary()
    if step["improved"]:
        assert result.best_error == pytest.approx(float(push(result.best_theta.values)), rel=1e-9)


@pytest.mark.parametrize("preset", ["bo", "random", "bo-gn"])
def test_an_assessed_preset_searches_its_budget_less_the_reserve_and_makes_at_most_its_budget(preset: str) -> None:
    """Every preset whose search is assessed keeps reserved_evaluations (D + 4 = 6 for D = 2) of the budget
    for after the search, so the run makes at most ``budget`` evaluations. σ² is unknown here (the "ess"
    rule evaluates the residuals at the best θ), so the assessment does spend some of the reserve."""
    rng = np.random.default_rng(0)
    A = rng.normal(size=(40, 2))
    objective = LinearObjective(A, A @ np.array([0.4, 0.6]) + 0.01 * rng.normal(size=40))
    budget, reserve = 16, reserved_evaluations(preset, 2)
    assert reserve == 2 + 4
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                          # 10 evaluations in 2-D: the GP budget warning
        result = run_preset(objective, preset, budget=budget, seed=0, progress=False)
    made = result.config["evaluations"]
    assert made["search"] == result.n_evaluations == budget - reserve
    assert made["after_search"] > 0 and made["total"] == made["search"] + made["after_search"]
    assert made["total"] <= budget


def test_a_handoff_preset_without_a_decoder_for_the_space_runs_without_its_latent_stage(push) -> None:
    with pytest.warns(PresetWarning, match="no latent decoder"):
        result = run_preset(push, "handoff", budget=20, seed=0, progress=False)
    assert result.config["stages"] == ["bo over the full space"]


def test_a_handoff_preset_carries_its_latent_evaluations_into_the_full_space(push) -> None:
    decoder = REMBO(push.space, dim=1, seed=0)
    preset = Preset("short-handoff", latent=6)
    with warnings.catch_warnings():
        warnings.simplefilter("error", PresetWarning)
        result = run_preset(push, preset, budget=14 + 6, seed=0, decoder=decoder, progress=False)
    assert result.n_evaluations == 14                     # 6 latent, 8 in the full space; D + 4 = 6 kept after
    image = decoder.decode(Grid.for_decoder(decoder, points_per_dim=11).points)
    for theta in result.history["theta"].values[:6]:
        assert np.min(np.abs(image - theta).max(axis=1)) < 1e-12
    assert result.config["stages"][0].startswith("latent (REMBO, 6 evaluations)")


def test_budgets_too_small_for_a_recipe_are_refused_with_the_numbers(push) -> None:
    with pytest.raises(BudgetError, match="at least 8"):
        run_preset(push, "bo-gn", budget=6, seed=0, progress=False)
    with pytest.raises(BudgetError, match="at least 8"):      # bo keeps the same D + 4 = 6 for its assessment
        run_preset(push, "bo", budget=7, seed=0, progress=False)
    with pytest.raises(BeliefError, match="needs decoder="):
        run_preset(push, "latent", budget=10, seed=0, progress=False)
    with pytest.raises(BeliefError, match="unknown preset"):
        resolve("fastest")
    with pytest.raises(BeliefError, match="full space only"):
        run_preset(push, "bo", budget=10, seed=0, decoder=Identity(push.space), progress=False)


def test_the_default_preset_is_a_named_recipe_with_every_stage() -> None:
    best = PRESETS[DEFAULT_PRESET]
    assert best.latent > 0 and best.search == "bo" and best.local_step


def test_identify_without_a_grid_is_the_default_preset(push) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        default = identify(push, budget=12, seed=2, progress=False)
        best = run_preset(push, DEFAULT_PRESET, budget=12, seed=2, progress=False)
    np.testing.assert_array_equal(default.history["theta"].values, best.history["theta"].values)
    assert default.config["preset"] == best.config["preset"] == DEFAULT_PRESET
    assert default.best_error == best.best_error


def test_identify_with_a_grid_is_one_search_and_refuses_mixed_requests(push) -> None:
    decoder = Identity(push.space)
    grid = Grid.for_decoder(decoder, points_per_dim=11)
    result = identify(push, decoder, grid, budget=8, seed=0, progress=False)
    assert "preset" not in result.config and result.n_evaluations == 8
    with pytest.raises(BeliefError, match="needs the decoder"):
        identify(push, grid=grid, budget=8, seed=0)
    with pytest.raises(BeliefError, match="not both"):
        identify(push, decoder, grid, budget=8, seed=0, preset="bo")
    with pytest.raises(BudgetError, match="needs budget="):
        identify(push, seed=0, time_budget=10.0)


def test_a_plain_function_runs_a_preset_and_keeps_its_best_without_residuals(push) -> None:
    def error(theta: np.ndarray) -> float:
        return float(push(theta))

    with pytest.warns(PresetWarning, match="needs residual vectors"):
        result = run_preset(error, "bo-gn", budget=14, seed=0, space=push.space, progress=False)
    assert "local_step" not in result.config and result.config["stages"] == ["bo over the full space"]
    assert result.n_evaluations == 14 - 6


@pytest.mark.slow
def test_the_default_preset_on_t6_data_uses_the_shipped_latent_decoder() -> None:
    from embeddings.pretrained import pretrained_decoder
    from physics import FlopController, ParameterSpace, TrajectoryObjective, simulate

    space = ParameterSpace.t6()
    assert pretrained_decoder(space) is not None, "embeddings/data/t6-ae-cf-5.json is missing: run `make pretrained`"
    data = simulate(space.replace(rod_length=1.70), controller=FlopController(heading=0.0), duration=0.6)
    with TrajectoryObjective([data], loss="squared", n_workers=0) as objective, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = identify(objective, budget=15 + 2 + 19, seed=0, progress=False)
        assert result.config["stages"][0] == "latent (DynamicsAutoencoder, 15 evaluations)"
        assert result.n_evaluations == 17 and result.config["evaluations"] == {"search": 17, "after_search": 19,
                                                                             "total": 36}
        assert result.best_error <= float(np.nanmin(result.history["error"].values))
        assert result.best_error == pytest.approx(float(objective(result.best_theta.values)), rel=1e-9)
