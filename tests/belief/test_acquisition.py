"""log EI: agrees with the direct formula, stays finite deep in the tail, is monotone; cell selection."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import norm

from belief import BeliefError, GPSurrogate, log_expected_improvement, log_h, select_cells


def test_log_h_matches_direct_formula_where_it_is_accurate() -> None:
    u = np.linspace(-8, 6, 301)
    direct = np.log(norm.pdf(u) + u * norm.cdf(u))
    np.testing.assert_allclose(log_h(u), direct, rtol=1e-9, atol=1e-12)


def test_log_h_finite_and_asymptotic_in_the_far_tail() -> None:
    u = -np.logspace(1, 12, 50)
    v = log_h(u)
    assert np.all(np.isfinite(v))
    # h(u) = phi(u) / u^2 (1 - 3/u^2 + O(u^-4)) for u -> -inf
    asym = -0.5 * u**2 - 0.5 * np.log(2 * np.pi) - 2 * np.log(-u)
    assert np.all(np.abs(v - asym) <= 3.5 / u**2 + 1e-15 * np.abs(asym))


@settings(max_examples=100, deadline=None)
@given(a=st.floats(-1e4, 50), b=st.floats(-1e4, 50))
def test_log_h_is_increasing(a: float, b: float) -> None:
    lo, hi = sorted((a, b))
    la, lb = log_h(np.array([lo, hi]))
    assert la <= lb + 1e-12 * abs(lb)


def test_log_ei_prefers_low_mean_and_high_variance() -> None:
    lei = log_expected_improvement(np.array([0.0, -1.0, 0.0, 5.0]), np.array([1.0, 1.0, 4.0, 1e-30]), best=0.0)
    assert lei[1] > lei[0] and lei[2] > lei[0]
    assert lei[3] == -np.inf  # no variance, no improvement
    with pytest.raises(BeliefError, match="same shape"):
        log_expected_improvement(np.zeros(2), np.zeros(3), 0.0)


def _model() -> tuple[GPSurrogate, np.ndarray]:
    bounds = np.array([[0.0, 1.0], [0.0, 1.0]])
    g = np.stack(np.meshgrid(np.linspace(0, 1, 15), np.linspace(0, 1, 15), indexing="ij"), -1).reshape(-1, 2)
    idx = np.array([0, 17, 50, 112, 160, 224, 200, 90])
    f = lambda z: np.sum((z - 0.3) ** 2, axis=1) + 0.05  # noqa: E731
    return GPSurrogate(bounds).fit(g[idx], f(g[idx])), g


def test_select_cells_skips_evaluated_and_batches_are_distinct() -> None:
    m, g = _model()
    avail = np.ones(len(g), dtype=bool)
    first = select_cells(m, g, avail, q=1)[0]
    avail2 = avail.copy()
    avail2[first] = False
    assert select_cells(m, g, avail2, q=1)[0] != first
    batch = select_cells(m, g, avail, q=4)
    assert len(set(batch)) == 4 and batch[0] == first
    assert select_cells(m, g, avail, q=4) == batch  # deterministic
    with pytest.raises(BeliefError, match="unevaluated cells left"):
        select_cells(m, g, np.zeros(len(g), dtype=bool), q=1)
    with pytest.raises(BeliefError, match="boolean mask"):
        select_cells(m, g, np.ones(3, dtype=bool), q=1)
