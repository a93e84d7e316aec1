"""The best cell's local spread (belief.spread): an interval is never the grid's resolution alone."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from linear_objective import LinearObjective
from scipy.stats import truncnorm

from belief import Belief
from belief.errors import BeliefError
from belief.grid import SobolCandidates
from belief.identify import identify
from belief.posterior import marginals
from belief.proposers import BOProposer, SobolDesign, WarmStart
from belief.spread import CellSpread
from embeddings import Identity
from physics import ParameterSpace
from physics.parameters import Parameter


def _space(dim: int) -> ParameterSpace:
    return ParameterSpace(tuple(Parameter(f"p{j}", "1", 0.5, 0.0, 1.0, "", minimum=-np.inf) for j in range(dim)))


def _cells(p: np.ndarray) -> xr.DataArray:
    return xr.DataArray(p / p.sum(), dims=("cell",))


@settings(max_examples=30, deadline=None)
@given(mu=st.floats(0.0, 1.0), s=st.floats(0.01, 2.0), level=st.sampled_from([0.5, 0.9, 0.95]))
def test_one_cell_holding_all_of_p_gives_the_truncated_normal(mu: float, s: float, level: float) -> None:
    theta = np.array([[mu], [0.3], [0.9]])
    m = marginals(_cells(np.array([1.0, 0.0, 0.0])), theta, _space(1), level=level,
                  spread=CellSpread(0, (s,)))
    law = truncnorm((0.0 - mu) / s, (1.0 - mu) / s, loc=mu, scale=s)
    assert float(m["lower"][0]) == pytest.approx(law.ppf(0.5 * (1 - level)), abs=1e-9)
    assert float(m["upper"][0]) == pytest.approx(law.ppf(0.5 * (1 + level)), abs=1e-9)
    assert float(m["mean"][0]) == pytest.approx(law.mean(), abs=1e-9)
    assert float(m["std"][0]) == pytest.approx(law.std(), abs=1e-9)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), level=st.sampled_from([0.5, 0.9]))
def test_a_zero_spread_changes_nothing(seed: int, level: float) -> None:
    rng = np.random.default_rng(seed)
    theta, p = rng.uniform(0, 1, (40, 3)), rng.dirichlet(np.full(40, 0.3))
    cell = int(rng.integers(40))
    bare = marginals(_cells(p), theta, _space(3), level=level)
    zero = marginals(_cells(p), theta, _space(3), level=level, spread=CellSpread(cell, (0.0, 0.0, 0.0)))
    for key in ("mean", "std", "lower", "upper"):
        assert np.allclose(zero[key].values, bare[key].values, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), level=st.sampled_from([0.5, 0.9]))
def test_the_interval_ends_are_the_mixture_quantiles(seed: int, level: float) -> None:
    """F(lower) >= (1 - level)/2 and F just below lower is smaller, with F the mixture's CDF."""
    rng = np.random.default_rng(seed)
    theta, p = rng.uniform(0, 1, (25, 1)), rng.dirichlet(np.ones(25))
    cell, s = int(np.argmax(p)), float(rng.uniform(0.01, 0.5))
    m = marginals(_cells(p), theta, _space(1), level=level, spread=CellSpread(cell, (s,)))
    law = truncnorm(-theta[cell, 0] / s, (1 - theta[cell, 0]) / s, loc=theta[cell, 0], scale=s)
    rest = np.arange(25) != cell

    def F(x: float) -> float:
        return float(p[rest] @ (theta[rest, 0] <= x)) + p[cell] * float(law.cdf(x))

    for end, q in (("lower", 0.5 * (1 - level)), ("upper", 0.5 * (1 + level))):
        x = float(m[end][0])
        assert F(x) >= q - 1e-9 and F(x - 1e-7) < q + 1e-9


def test_an_infinite_spread_is_uniform_over_the_box() -> None:
    m = marginals(_cells(np.array([1.0, 0.0])), np.array([[0.2], [0.7]]), _space(1), level=0.9,
                  spread=CellSpread(0, (np.inf,)))
    assert (float(m["lower"][0]), float(m["upper"][0])) == pytest.approx((0.05, 0.95), abs=1e-9)
    assert float(m["std"][0]) == pytest.approx(1 / np.sqrt(12), rel=1e-9)


def test_a_belief_keeps_its_spread_through_a_file(tmp_path) -> None:
    space = _space(2)
    grid = SobolCandidates(np.array([[0.0, 1.0]] * 2), n=3, seed=0)
    p = np.full(grid.size, 0.02 / (grid.size - 1))
    p[0] = 0.98
    b = Belief(grid.to_dataarray(p), grid.points, space, decoder_config=Identity(space).config(),
               grid_config=grid.config(), grid=grid, spread=CellSpread(0, (0.05, np.inf)))
    b.save(tmp_path / "b.nc")
    back = Belief.load(tmp_path / "b.nc")
    assert back.spread == b.spread and np.allclose(back.interval(), b.interval())
    assert b.interval()[0, 1] > b.interval()[0, 0] and "spread by its local width" in b.summary()
    with pytest.raises(BeliefError, match="CellSpread of one of the"):
        Belief(b.P, b.theta, space, decoder_config=b.decoder_config, grid_config=b.grid_config,
               spread=CellSpread(7, (0.1, 0.1)))
    with pytest.raises(BeliefError, match="stds >= 0"):
        CellSpread(0, (-0.1, 0.1))


def test_a_warm_start_holding_all_of_p_gets_the_data_width_and_holds_the_truth() -> None:
    """A warm cell 0.7 local stds from the truth takes all of P (every cell evaluated, so no GP
    guess spreads it): its interval alone is one point that misses the truth; with the spread it
    is the data's width and holds it."""
    rng = np.random.default_rng(3)
    A, truth, sigma = rng.normal(size=(30, 2)), np.array([0.4, 0.6]), 0.01
    obj = LinearObjective(A, A @ truth + sigma * rng.normal(size=30), noise_var=sigma ** 2, noise_floor=sigma ** 2)
    local_std = sigma * np.sqrt(np.diag(np.linalg.inv(A.T @ A)))
    warm = truth + 0.7 * local_std
    decoder = Identity(obj.space)
    grid = SobolCandidates(decoder.bounds, n=16, seed=0, include=decoder.encode(warm[None]))
    result = identify(obj, decoder, grid, budget=grid.size, seed=0, progress=False,
                      proposer=BOProposer(0, initial=WarmStart([0], SobolDesign(0))))
    b = result.belief
    assert b.p[0] > 0.99 and b.spread is not None and b.spread.cell == 0
    assert np.allclose(b.spread.std, local_std, rtol=0.02)
    bare = Belief(b.P, b.theta, obj.space, decoder_config=b.decoder_config, grid_config=b.grid_config)
    for j in range(2):
        lo, hi = bare.interval()[j]
        assert lo == hi == pytest.approx(warm[j]) and not lo <= truth[j] <= hi     # the grid's resolution
        lo, hi = b.interval()[j]
        assert lo < truth[j] < hi
        assert (hi - lo) / (2 * 1.6449 * local_std[j]) == pytest.approx(1.0, rel=0.05)     # the data's width
