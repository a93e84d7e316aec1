"""The noise rules of the likelihood posterior: effective residual counts from residual structure."""
from __future__ import annotations

import numpy as np
import pytest

from belief.errors import BeliefError
from belief.noise import effective_size, iid_noise_var, noise_var_from_residuals, segment_discrepancy


def _ar1(T: int, m: int, phi: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.empty((T, m))
    x[0] = rng.standard_normal(m) / np.sqrt(1 - phi**2)
    for i in range(1, T):
        x[i] = phi * x[i - 1] + rng.standard_normal(m)
    return x


def test_white_noise_counts_every_residual() -> None:
    r = np.random.default_rng(0).standard_normal((2000, 6))
    size = effective_size([r])
    assert size.tau[0] == pytest.approx(1.0, abs=0.15)
    assert size.coords[0] == pytest.approx(6.0, rel=0.05)
    assert size.n_eff == pytest.approx(size.n, rel=0.2)


@pytest.mark.parametrize("phi", [0.5, 0.8, 0.9])
def test_ar1_autocorrelation_time_matches_theory(phi: float) -> None:
    # τ = (1 + φ) / (1 - φ) for an AR(1) process
    taus = [effective_size([_ar1(4000, 4, phi, seed)]).tau[0] for seed in range(5)]
    assert np.median(taus) == pytest.approx((1 + phi) / (1 - phi), rel=0.2)


def test_shared_residual_across_coordinates_is_one_coordinate() -> None:
    base = np.random.default_rng(1).standard_normal((1000, 1))
    r = base @ np.ones((1, 36))               # every coordinate repeats one series
    assert effective_size([r]).coords[0] == pytest.approx(1.0, abs=1e-6)


def test_constant_bias_counts_as_about_one_number() -> None:
    r = np.full((300, 3), 0.01) + 1e-6 * np.random.default_rng(2).standard_normal((300, 3))
    size = effective_size([r])
    assert size.n == 900
    assert size.n_eff < 3.5                   # one number per (effectively one) coordinate


def test_nan_rows_are_skipped_and_segments_add_up() -> None:
    rng = np.random.default_rng(3)
    a, b = rng.standard_normal((500, 3)), rng.standard_normal((400, 3))
    a[::7] = np.nan
    both = effective_size([a, b])
    assert both.samples == (500 - 72, 400)
    assert both.n == (500 - 72 + 400) * 3
    assert both.n_eff == pytest.approx(effective_size([a]).n_eff + effective_size([b]).n_eff)


def test_ess_rule_tempers_the_iid_rule_by_k_over_k_eff() -> None:
    r = _ar1(3000, 2, 0.9, 4)
    E = np.array([float(np.sum(r**2)), 2.0 * float(np.sum(r**2))])
    sigma2, size = noise_var_from_residuals(E, [r], dim=3)
    base = iid_noise_var(E, n_observations=size.n, dim=3)
    assert sigma2 == pytest.approx(base * size.n / size.n_eff)
    assert sigma2 > 10 * base                # τ ≈ 19 for φ = 0.9


def test_bad_residuals_raise_typed_errors() -> None:
    with pytest.raises(BeliefError, match="at least one residual segment"):
        effective_size([])
    with pytest.raises(BeliefError, match="every residual row is NaN"):
        effective_size([np.full((4, 2), np.nan)])
    with pytest.raises(BeliefError, match="T x m array"):
        effective_size([np.zeros((2, 2, 2))])
    with pytest.raises(BeliefError, match="non-negative errors"):
        iid_noise_var(np.array([-1.0, 2.0]), n_observations=10, dim=1)


def test_segment_discrepancy_measures_disagreement_between_segments() -> None:
    agree = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])
    assert segment_discrepancy(agree) == 0.0
    # the best total (row 0) fits segment 1 twice as badly as row 1 does
    disagree = np.array([[1.0, 2.0], [5.0, 1.0], [3.0, 3.0]])
    assert segment_discrepancy(disagree) == pytest.approx(np.median([0.0, 0.5]))
    assert segment_discrepancy(np.array([[1.0], [2.0]])) == 0.0
    with pytest.raises(BeliefError, match="n x S"):
        segment_discrepancy(np.array([1.0, 2.0]))


def test_discrepancy_floors_the_sharpness_relative_to_e_min() -> None:
    r = np.random.default_rng(5).standard_normal((3000, 4))        # white: K_eff ≈ K
    E = np.array([float(np.sum(r**2)), 1.5 * float(np.sum(r**2))])
    plain, _ = noise_var_from_residuals(E, [r], dim=2)
    floored, _ = noise_var_from_residuals(E, [r], dim=2, discrepancy=0.05)
    assert floored == pytest.approx(0.5 * 0.05 * E.min())
    assert floored > 100 * plain
    with pytest.raises(BeliefError, match="discrepancy"):
        noise_var_from_residuals(E, [r], dim=2, discrepancy=-1.0)


def test_the_summary_line_names_what_set_sigma2() -> None:
    from belief.result import noise_text

    info = {"n_effective": 50.0, "n_observations": 20000, "discrepancy": 0.2, "segment_discrepancy": 0.01}
    floor = noise_text({"noise_var": 0.1 * 4.0, "noise_rule": "ess", "best_error": 4.0, "noise": info})
    assert "discrepancy δ = 0.2 (the model-error floor δ_0)" in floor and "20% above the best" in floor
    segs = noise_text({"noise_var": 0.6, "noise_rule": "ess", "best_error": 4.0,
                       "noise": {**info, "discrepancy": 0.3, "segment_discrepancy": 0.3}})
    assert "the segments' disagreement" in segs
    counted = noise_text({"noise_var": 4.0 / 5, "noise_rule": "ess", "best_error": 4.0, "noise": info})
    assert "set by the residuals: 50 effective of 20000" in counted
    assert noise_text({"noise_var": 2.0, "noise_rule": "iid", "best_error": 4.0, "noise": {}}) == \
        "likelihood σ² = 2 (iid)"
    assert noise_text({"noise_var": None, "noise_rule": "none (minimizer mode)"}) == ""
