"""The likelihood's scale from the data (belief.scale): blocks for its size, the noise floor for adequacy."""
from __future__ import annotations

import numpy as np
import pytest

from belief.errors import BeliefError
from belief.scale import ScaleConfig, block_scores, calibrated_scale

K, D, SIGMA = 2400, 3, 0.01


def _segments(r: np.ndarray, n: int = 4) -> list[np.ndarray]:
    return [part[:, None] for part in np.array_split(r, n)]


def _jacobian(seed: int) -> np.ndarray:
    """Smooth columns (slow sines), as the sensitivities of a trajectory to its parameters are."""
    t = np.linspace(0, 1, K)
    phases = np.random.default_rng(seed).uniform(0, 2 * np.pi, D)
    return np.column_stack([np.sin(2 * np.pi * (k + 1) * t + p) for k, p in enumerate(phases)])


def test_white_noise_gives_its_variance_and_an_adequate_model() -> None:
    ratios = []
    for seed in range(20):
        r = np.random.default_rng(seed).normal(0, SIGMA, K)
        scale = calibrated_scale(_segments(r), _jacobian(seed), noise_floor=SIGMA ** 2)
        ratios.append(scale.blocks_var / SIGMA ** 2)
        assert scale.adequacy == pytest.approx(1.0, abs=0.1) and scale.discrepancy == 0.0
        assert scale.noise_var == max(scale.blocks_var, scale.error / (K - D))
    assert np.median(ratios) == pytest.approx(1.0, abs=0.15)      # unbiased on average
    assert 0.5 < min(ratios) and max(ratios) < 1.8                # 96 blocks x 3 directions


def test_correlated_residuals_widen_the_scale_where_the_parameters_look() -> None:
    """A moving average of 5 white samples (variance σ²) seen through smooth sensitivities has 5 times
    the score variance of white noise: the block sandwich sees it, the count of residuals does not."""
    ratios = []
    for seed in range(10):
        white = np.random.default_rng(seed).normal(0, SIGMA * np.sqrt(5), K + 4)
        r = np.convolve(white, np.ones(5) / 5, mode="valid")
        scale = calibrated_scale(_segments(r), _jacobian(seed), noise_floor=SIGMA ** 2)
        ratios.append(scale.blocks_var / SIGMA ** 2)
    assert np.median(ratios) == pytest.approx(5.0, rel=0.3)


def test_noise_that_cancels_in_the_scores_does_not_sharpen_beyond_independent_noise() -> None:
    """r_i = ε_i − ε_{i−1}: the scores of smooth sensitivities nearly cancel (σ²_blocks ≪ σ²), but
    σ² stays at the independent-residual value E/(K − D)."""
    eps = np.random.default_rng(6).normal(0, SIGMA, K + 1)
    r = eps[1:] - eps[:-1]
    scale = calibrated_scale(_segments(r), _jacobian(6), noise_floor=2 * SIGMA ** 2)
    assert scale.blocks_var < 0.1 * scale.error / K
    assert scale.noise_var == pytest.approx(scale.error / (K - D)) and "independent residuals" in scale.text()


def test_a_shared_bias_keeps_the_model_error_floor_in_proportion() -> None:
    rng = np.random.default_rng(3)
    t = np.linspace(0, 1, K)
    r = rng.normal(0, SIGMA, K) + 3 * SIGMA * np.sin(40 * t)         # residuals 5.5 times the noise's variance
    scale = calibrated_scale(_segments(r), _jacobian(3), noise_floor=SIGMA ** 2, config=ScaleConfig(discrepancy=0.2))
    assert scale.adequacy == pytest.approx(5.5, rel=0.1)
    assert scale.discrepancy == pytest.approx(0.2 * (1 - 1.25 / scale.adequacy))
    assert scale.noise_var == pytest.approx(0.5 * scale.discrepancy * scale.error) and "model error" in scale.text()


def test_an_unknown_noise_floor_keeps_the_full_floor() -> None:
    r = np.random.default_rng(4).normal(0, SIGMA, K)
    scale = calibrated_scale(_segments(r), _jacobian(4), noise_floor=None, config=ScaleConfig(discrepancy=0.2))
    assert scale.adequacy is None and scale.discrepancy == 0.2
    assert scale.noise_var == pytest.approx(0.1 * scale.error)


def test_block_scores_sum_to_the_gradient() -> None:
    rng = np.random.default_rng(5)
    segs = [rng.normal(size=(30, 2)), rng.normal(size=(47, 2))]
    J = rng.normal(size=(154, 4))
    g = block_scores(segs, J, block=10)
    r = np.concatenate([s.ravel() for s in segs])
    assert g.shape == (3 + 5, 4)                 # 30 rows: 3 blocks; 47: 4 of 10 and one of 7
    assert np.allclose(g.sum(axis=0), J.T @ r)


@pytest.mark.parametrize("kwargs, match", [({"block": 1}, "block"), ({"tolerance": 0.5}, "tolerance"),
                                           ({"discrepancy": -0.1}, "discrepancy")])
def test_bad_settings_are_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(BeliefError, match=match):
        ScaleConfig(**kwargs)


def test_a_jacobian_of_the_wrong_size_is_refused() -> None:
    with pytest.raises(BeliefError, match="Jacobian"):
        calibrated_scale(_segments(np.zeros(K) + 1.0), np.ones((K - 1, D)), noise_floor=None)
