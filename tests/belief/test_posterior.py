"""Posterior P: a distribution, invariant to evaluation order, correct closed forms, credible sets, marginals."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from belief import (
    BeliefError,
    GPSurrogate,
    Grid,
    PosteriorConfig,
    credible_mask,
    entropy,
    estimate_noise_var,
    log_likelihood,
    marginals,
    posterior_from_surrogate,
)
from embeddings import Identity
from physics.push import push_space


def _fit(push_problem, n: int = 25, seed: int = 0, perm: np.ndarray | None = None):
    obj, truth = push_problem(seed=seed)
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=21)
    idx = np.random.default_rng(seed).choice(grid.size, n, replace=False)
    if perm is not None:
        idx = idx[perm]
    z = grid.points[idx]
    e = np.array([obj(t) for t in dec.decode(z)])
    return GPSurrogate(grid.bounds).fit(z, e), grid, obj


@pytest.mark.parametrize("mode", ["likelihood", "minimizer"])
def test_P_is_a_distribution_over_the_grid(push_problem, mode: str) -> None:
    m, grid, obj = _fit(push_problem)
    P = posterior_from_surrogate(m, grid, config=PosteriorConfig(mode=mode), noise_var=obj.noise_var, seed=1)
    assert isinstance(P, xr.DataArray) and P.dims == ("z0", "z1") and P.name == "P"
    assert np.all(P.values >= 0) and P.values.sum() == pytest.approx(1.0, abs=1e-12)
    assert 0 <= entropy(P) <= np.log(grid.size) + 1e-12


@pytest.mark.parametrize("mode", ["likelihood", "minimizer"])
def test_P_is_invariant_to_the_order_of_evaluations(push_problem, mode: str) -> None:
    perm = np.random.default_rng(9).permutation(25)
    a, grid, obj = _fit(push_problem)
    b, _, _ = _fit(push_problem, perm=perm)
    cfg = PosteriorConfig(mode=mode)
    Pa = posterior_from_surrogate(a, grid, config=cfg, noise_var=obj.noise_var, seed=3)
    Pb = posterior_from_surrogate(b, grid, config=cfg, noise_var=obj.noise_var, seed=3)
    assert np.array_equal(Pa.values, Pb.values)


def test_minimizer_mode_is_seeded(push_problem) -> None:
    m, grid, _ = _fit(push_problem)
    cfg = PosteriorConfig(mode="minimizer", n_samples=500)
    P1 = posterior_from_surrogate(m, grid, config=cfg, seed=1)
    P2 = posterior_from_surrogate(m, grid, config=cfg, seed=1)
    P3 = posterior_from_surrogate(m, grid, config=cfg, seed=2)
    assert np.array_equal(P1.values, P2.values) and not np.array_equal(P1.values, P3.values)


def test_failed_cells_get_zero_mass(push_problem) -> None:
    m, grid, obj = _fit(push_problem)
    failed = np.zeros(grid.size, dtype=bool)
    failed[::3] = True
    P = posterior_from_surrogate(m, grid, config=PosteriorConfig(), noise_var=obj.noise_var, failed=failed)
    assert np.all(P.values.ravel()[failed] == 0) and P.values.sum() == pytest.approx(1.0)


@settings(max_examples=30, deadline=None)
@given(m=st.floats(-2.0, 3.0), s=st.floats(0.05, 2.0), sigma2=st.floats(0.1, 2.0))
def test_rectified_closed_form_matches_monte_carlo(m: float, s: float, sigma2: float) -> None:
    f = m + s * np.random.default_rng(0).standard_normal(400_000)
    mc = np.mean(np.exp(-np.maximum(f, 0) / (2 * sigma2)))
    closed = np.exp(log_likelihood(np.array([m]), np.array([s**2]), noise_var=sigma2, shift=None))[0]
    assert closed == pytest.approx(mc, rel=5e-3, abs=5e-4)


def test_closed_form_reduces_to_the_gaussian_formula_far_from_zero() -> None:
    m, s, sigma2 = np.array([8.0]), np.array([0.3]), 0.7
    got = log_likelihood(m, s**2, noise_var=sigma2, shift=None)[0]
    assert got == pytest.approx(-m[0] / (2 * sigma2) + s[0] ** 2 / (8 * sigma2**2), rel=1e-9)


def test_log_transform_quadrature_matches_monte_carlo() -> None:
    m, s, shift, sigma2 = -1.0, 0.8, -0.05, 0.2
    f = m + s * np.random.default_rng(1).standard_normal(400_000)
    mc = np.mean(np.exp(-np.maximum(np.exp(f) + shift, 0) / (2 * sigma2)))
    q = np.exp(log_likelihood(np.array([m]), np.array([s**2]), noise_var=sigma2, shift=shift))[0]
    assert q == pytest.approx(mc, rel=2e-3)


@settings(max_examples=50, deadline=None)
@given(p=arrays(np.float64, 40, elements=st.floats(0.0, 1.0)), level=st.floats(0.05, 0.95))
def test_credible_mask_is_the_smallest_set_reaching_the_level(p: np.ndarray, level: float) -> None:
    if p.sum() == 0:
        p = p + 1.0
    p = p / p.sum()
    mask = credible_mask(p, level=level)
    assert p[mask].sum() >= level - 1e-12
    # minimal: dropping its least probable cell falls below the level
    smallest = np.min(p[mask])
    assert p[mask].sum() - smallest < level + 1e-12
    # highest density: every included cell is at least as probable as every excluded one
    if (~mask).any():
        assert p[mask].min() >= p[~mask].max()


def test_marginals_uniform_and_concentrated() -> None:
    space = push_space()
    dec = Identity(space)
    grid = Grid.for_decoder(dec, points_per_dim=11)
    theta = dec.decode(grid.points)
    uni = grid.to_dataarray(np.full(grid.size, 1.0 / grid.size))
    mu = marginals(uni, theta, space)
    np.testing.assert_allclose(mu["std"], mu["prior_std"])
    assert not mu["identified"].any()
    # prior std of a regular grid approaches width / sqrt(12)
    np.testing.assert_allclose(mu["prior_std"], (space.upper - space.lower) / np.sqrt(12), rtol=0.1)
    p = np.zeros(grid.size)
    p[60] = 1.0
    mc = marginals(grid.to_dataarray(p), theta, space)
    assert mc["identified"].all()
    np.testing.assert_allclose(mc["mean"], theta[60])
    np.testing.assert_allclose(mc["lower"], theta[60])
    np.testing.assert_allclose(mc["upper"], theta[60])
    np.testing.assert_allclose(mc["map"], theta[60])
    assert list(mc["unit"].values) == ["kg", "1"]
    # concentrated along mu only: m identified, mu not
    p = np.zeros(grid.size)
    p[np.arange(grid.size) // 11 == 4] = 1.0 / 11
    mm = marginals(grid.to_dataarray(p), theta, space)
    assert bool(mm["identified"].sel(parameter="m")) and not bool(mm["identified"].sel(parameter="mu"))


def test_estimate_noise_var() -> None:
    assert estimate_noise_var(np.array([0.6, 2.0, np.nan]), n_observations=8, dim=2) == pytest.approx(0.1)
    assert estimate_noise_var(np.array([0.0, 2.0])) > 0
    with pytest.raises(BeliefError, match="non-negative errors"):
        estimate_noise_var(np.array([-1.0, 2.0]))
    with pytest.raises(BeliefError, match="no successful evaluation"):
        estimate_noise_var(np.array([np.nan]))


def test_likelihood_needs_noise_var_and_non_negative_errors(push_problem) -> None:
    m, grid, _ = _fit(push_problem)
    with pytest.raises(BeliefError, match="needs noise_var"):
        posterior_from_surrogate(m, grid, config=PosteriorConfig())
    z = grid.points[:5]
    neg = GPSurrogate(grid.bounds, config=type(m.config)(log_transform=False)).fit(z, np.arange(5.0) - 2)
    with pytest.raises(BeliefError, match="non-negative errors"):
        posterior_from_surrogate(neg, grid, config=PosteriorConfig(), noise_var=1.0)
    with pytest.raises(BeliefError, match="zero everywhere"):
        posterior_from_surrogate(m, grid, config=PosteriorConfig(), noise_var=1.0,
                                 failed=np.ones(grid.size, dtype=bool))


@pytest.mark.parametrize(
    "kw, match",
    [({"mode": "argmax"}, "mode"), ({"noise_var": -1.0}, "noise_var"), ({"n_samples": 0}, "n_samples"),
     ({"max_subset": 1}, "max_subset"), ({"level": 1.0}, "level"), ({"identified_ratio": 0.0}, "identified_ratio")],
)
def test_config_validation(kw: dict, match: str) -> None:
    with pytest.raises(BeliefError, match=match):
        PosteriorConfig(**kw)
