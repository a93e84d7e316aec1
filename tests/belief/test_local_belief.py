"""P at the data's resolution (belief.local_belief): sharp where the data are, calibrated, the prior elsewhere."""
from __future__ import annotations

import numpy as np
import pytest
from linear_objective import LinearObjective

from belief import Belief, identify
from belief.curvature import secant_information
from belief.errors import BeliefError
from belief.local_belief import LocalConfig, _data_jacobian, fisher_information, pinned_directions, towards_prior
from belief.spread import ComplementSpread
from physics.measurements import Measurement, MeasurementPrior

SIGMA = 0.05


class Linear(LinearObjective):
    """E(θ) = ||y − Aθ||², y = Aθ* + ε, over the unit box; four segments; the noise unknown to belief
    but its floor σ² declared (what a trajectory objective measures from its data)."""

    def __init__(self, A: np.ndarray, y: np.ndarray) -> None:
        super().__init__(A, y, segments=4, noise_floor=SIGMA ** 2)


def _problem(seed: int, columns: np.ndarray | None = None) -> tuple[Linear, np.ndarray]:
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(400, 3)) if columns is None else columns
    truth = rng.uniform(0.3, 0.7, A.shape[1])
    return Linear(A, A @ truth + rng.normal(0, SIGMA, A.shape[0])), truth


def _exact_std(A: np.ndarray) -> np.ndarray:
    return SIGMA * np.sqrt(np.diag(np.linalg.inv(A.T @ A)))


def test_the_belief_is_local_with_the_data_width_and_holds_the_truth() -> None:
    obj, truth = _problem(0)
    result = identify(obj, budget=12, seed=0, preset="bo-local", progress=False)
    b = result.belief
    assert isinstance(b.spread, ComplementSpread) and b.decoder_config["kind"] == "local"
    assert result.config["local_stage"]["directions"] == 3
    m = b.marginals()
    width = (m["upper"] - m["lower"]).values
    exact = 2 * 1.6449 * _exact_std(obj.A)
    assert np.all(width < 2 * exact) and np.all(width > 0.5 * exact)           # sharp, not sharper
    assert np.all((m["lower"].values <= truth) & (truth <= m["upper"].values))
    assert list(b.verdict) == ["identified"] * 3
    draws = b.sample(2000, seed=0)
    assert np.allclose(draws.std(axis=0), _exact_std(obj.A), rtol=0.35)


def test_90_percent_intervals_cover_the_truth_at_the_stated_rate() -> None:
    """30 problems x 3 parameters: a calibrated 90 % interval misses about 9 of 90; fewer than 81
    covered happens with probability under 1 % (binomial)."""
    covered = 0
    for seed in range(30):
        obj, truth = _problem(100 + seed)
        m = identify(obj, budget=10, seed=seed, preset="bo-local", progress=False,
                     local=LocalConfig(budget=10)).belief.marginals()
        covered += int(np.sum((m["lower"].values <= truth) & (truth <= m["upper"].values)))
    assert covered >= 73


def test_a_direction_the_data_do_not_see_keeps_its_prior() -> None:
    """Two identical columns: only their sum is pinned; each alone keeps the box's spread given that sum
    (here 1.21: p0 is uniform on [0.21, 1], std 79 % of the prior's)."""
    rng = np.random.default_rng(7)
    col = rng.normal(size=400)
    A = np.column_stack([col, col, rng.normal(size=400)])
    obj, truth = _problem(7, A)
    b = identify(obj, budget=12, seed=0, preset="bo-local", progress=False).belief
    assert "identified" not in b.verdict[:2] and b.verdict[2] == "identified"
    m = b.marginals()
    assert np.all(m["std"].values[:2] > 0.7 / np.sqrt(12))
    draws = b.sample(4000, seed=1)
    assert np.std(draws[:, 0] + draws[:, 1]) < 0.05 * np.std(draws[:, 0])        # the sum is pinned


def test_one_pinned_direction_makes_a_grid_smaller_than_the_budget() -> None:
    """Three identical columns: the data see only their sum, a grid of 7 cells for a budget of 20."""
    col = np.random.default_rng(12).normal(size=400)
    obj, truth = _problem(12, np.column_stack([col, col, col]))
    result = identify(obj, budget=12, seed=0, preset="bo-local", progress=False)
    assert result.config["local_stage"]["directions"] == 1 and result.config["local_stage"]["evaluations"] == 7
    draws = result.belief.sample(2000, seed=0)
    assert np.std(draws.sum(axis=1)) < 0.1 * np.std(draws[:, 0])


def test_a_measurement_pins_what_the_data_leave_free() -> None:
    rng = np.random.default_rng(8)
    col = rng.normal(size=400)
    A = np.column_stack([col, col, rng.normal(size=400)])
    obj, truth = _problem(8, A)
    prior = MeasurementPrior(obj.space, (Measurement("p0", float(truth[0]), 0.002),))
    b = identify(obj, budget=12, seed=0, preset="bo-local", progress=False, measurements=prior).belief
    m = b.marginals()
    assert "not identified" not in b.verdict
    assert np.all((m["lower"].values <= truth) & (truth <= m["upper"].values))
    assert float(m["std"][1]) < 0.01                    # without the measurement it keeps most of the box's 0.29


def test_the_local_belief_round_trips_through_a_file(tmp_path) -> None:
    obj, _ = _problem(9)
    b = identify(obj, budget=12, seed=0, preset="bo-local", progress=False).belief
    b.save(tmp_path / "b.nc")
    back = Belief.load(tmp_path / "b.nc")
    assert back.spread == b.spread and np.allclose(back.interval(), b.interval())
    assert np.array_equal(back.sample(50, seed=3), b.sample(50, seed=3))
    assert back.decoder().config() == b.decoder().config()


def test_pinned_directions_follow_the_information() -> None:
    J = np.diag([100.0, 10.0, 0.1])
    d = pinned_directions(J, 1.0, dim=4)
    assert d.grid == 2                                          # λ = 1e4, 100 > 12; 0.01 is not
    assert np.allclose(np.abs(d.basis[:, 0]), [1 / np.sqrt(1e4 + 12), 0, 0])
    assert d.complement[2, 2] == pytest.approx(1 / (0.01 + 12))
    rotated = pinned_directions(np.array([[1.0, 1.0], [0.0, 0.0]]), 1.0, dim=2)
    assert rotated.grid == 0                            # (1, 1) carries 2 < its prior's 12 x 0.5
    assert rotated.complement[0, 0] == pytest.approx(0.5 / (2 + 6) + 0.5 / 6)


@pytest.mark.parametrize("kwargs, match", [({"dim": 0}, "dim"), ({"dim": 7}, "too large"),
                                           ({"span": -1.0}, "span"), ({"starts": True}, "starts"),
                                           ({"probe_sds": 0.0}, "probe_sds")])
def test_bad_settings_are_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(BeliefError, match=match):
        LocalConfig(**kwargs)


class Saturating(Linear):
    """y = A h(θ), h_j = θ0_j + c tanh((θ_j − θ0_j)/c) for j = 0 (the others linear): near θ0 the
    same Jacobian as the linear model, beyond c the data stop telling θ_0 apart."""

    def __init__(self, A: np.ndarray, y: np.ndarray, theta0: np.ndarray, c: float) -> None:
        super().__init__(A, y)
        self.theta0, self.c = theta0, c

    def mean(self, theta: np.ndarray) -> np.ndarray:
        h = np.asarray(theta, float).copy()
        h[0] = self.theta0[0] + self.c * np.tanh((h[0] - self.theta0[0]) / self.c)
        return self.A @ h


def test_e_measures_its_own_curvature_and_only_ever_lowers_f() -> None:
    """On a linear model the measured information is F; where the data saturate beyond c (one sd of
    θ_0), E rises less than F says and θ_0's information drops; it is never above F (Loewner order)."""
    rng = np.random.default_rng(11)
    A = rng.normal(size=(400, 3))
    A[:, 1] += 0.7 * A[:, 0]                                    # θ_0 trades off with θ_1
    theta0 = np.array([0.5, 0.5, 0.5])
    y = A @ theta0 + rng.normal(0, SIGMA, 400)
    F = fisher_information(-A, SIGMA ** 2)
    linear = secant_information(Linear(A, y), theta0, F, SIGMA ** 2, reach=2.0)
    assert linear.evaluations == 1 + 2 * 3 + 3
    np.testing.assert_allclose(linear.information, F, rtol=1e-6)
    flat = secant_information(Saturating(A, y, theta0, c=_exact_std(A)[0]), theta0, F, SIGMA ** 2, reach=2.0)
    assert flat.ratio.min() < 0.5
    assert np.linalg.eigvalsh(F - flat.information).min() > -1e-6 * np.abs(F).max()
    cov, cov_flat = np.linalg.inv(F + 12 * np.eye(3)), np.linalg.inv(flat.information + 12 * np.eye(3))
    assert cov_flat[0, 0] > 1.5 * cov[0, 0] and cov_flat[2, 2] == pytest.approx(cov[2, 2], rel=0.05)


def test_an_unseen_direction_is_centred_on_the_box_not_on_where_the_fit_stopped() -> None:
    d = pinned_directions(np.diag([100.0, 0.1]), 1.0, dim=4)
    assert d.grid == 1
    moved = towards_prior(np.array([0.3, 0.95]), d)
    assert moved[0] == pytest.approx(0.3) and moved[1] == pytest.approx(0.5, abs=1e-3)


def test_the_profile_leaves_a_quadratic_e_at_its_laplace_width() -> None:
    obj, _ = _problem(11)
    result = identify(obj, budget=12, seed=0, preset="bo-local", progress=False)
    profile = result.config["local_stage"]["profile"]
    assert np.all(np.array(profile["stretch"]) < 1.15) and profile["evaluations"] > 1 + 2 * 3


def test_what_the_data_pin_is_what_p_shows() -> None:
    """The identifiability map reads the information P was built from: E's measured curvature,
    widened by the profiles, less the measurements (its Jacobian J' gives J'ᵀJ'/σ² = S⁻¹FS⁻¹ − GᵀG);
    on a linear model its marginal widths are P's."""
    rng = np.random.default_rng(4)
    B = rng.normal(size=(3, 3))
    F, G, stretch = B.T @ B * 50 + 5 * np.eye(3), rng.normal(size=(1, 3)), np.array([1.0, 2.0, 1.5])
    J = _data_jacobian(F, 0.3, G, stretch)
    np.testing.assert_allclose(J.T @ J / 0.3, F / np.outer(stretch, stretch) - G.T @ G, atol=1e-9)
    obj, _ = _problem(11)
    result = identify(obj, budget=12, seed=0, preset="bo-local", progress=False)
    pct = np.array(result.identifiability.marginal_pct)
    std = 100 * result.belief.marginals()["std"].values / 0.5
    np.testing.assert_allclose(pct, std, rtol=0.1)
