"""P never contradicts its evaluations: the likelihood's evaluated floor and the "evaluated support" verdict rule.

The mechanism (belief.posterior, docs/identification.md): with σ² estimated from the evaluations,
E is floored at the best evaluated error, so no cell outweighs the best evaluation, and a
parameter whose interval still excludes the best evaluated θ is not identified
(belief.verdicts.unsupported). These tests need no simulator;
tests/belief/test_testbed_regression.py holds the case on the foreign testbed.
"""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import integrate

from belief.errors import BeliefError
from belief.grid import SobolCandidates
from belief.posterior import PosteriorConfig, error_floor, log_likelihood, marginals, posterior_from_surrogate
from belief.surrogate import GPSurrogate
from belief.verdicts import decide, trust_note, unsupported
from embeddings import Identity
from physics.parameters import Parameter, ParameterSpace


def _space(D: int) -> ParameterSpace:
    return ParameterSpace(tuple(Parameter(f"x{i}", "1", 0.5, 0.0, 1.0, minimum=-1.0) for i in range(D)))


@settings(max_examples=60, deadline=None)
@given(m=st.floats(-4.0, 4.0), s=st.floats(1e-3, 3.0), sigma2=st.floats(1e-4, 2.0), floor=st.floats(0.0, 2.0),
       below=st.floats(1e-3, 5.0), log=st.booleans())
def test_no_cell_outweighs_the_best_evaluation(m: float, s: float, sigma2: float, floor: float, below: float,
                                               log: bool) -> None:
    """log E_f[exp(-max(E, F)/(2σ²))] <= -F/(2σ²) whatever the GP predicts (mean far below F, wide tails)."""
    shift = floor - below if log else None
    ll = log_likelihood(np.array([m]), np.array([s**2]), noise_var=sigma2, shift=shift, floor=floor)[0]
    assert ll <= -floor / (2 * sigma2) + 1e-9 * max(1.0, floor / sigma2)


@pytest.mark.parametrize("shift", [None, -0.3, 0.2])
def test_the_floored_likelihood_matches_monte_carlo(shift: float | None) -> None:
    rng = np.random.default_rng(2)
    m, s, sigma2, floor = (0.4, 0.5, 0.3, 0.5) if shift is None else (-0.5, 0.7, 0.2, 0.45)
    f = m + s * rng.standard_normal(400_000)
    e = f if shift is None else np.exp(f) + shift
    mc = np.mean(np.exp(-np.maximum(e, floor) / (2 * sigma2)))
    got = np.exp(log_likelihood(np.array([m]), np.array([s**2]), noise_var=sigma2, shift=shift, floor=floor))[0]
    assert got == pytest.approx(mc, rel=3e-3)


@pytest.mark.parametrize("s", [1e-3, 0.05, 0.7, 3.0])
@pytest.mark.parametrize("dm", [-2.0, -0.3, 0.0, 1.0, 2.0])
@pytest.mark.parametrize("nats", [1.0, 20.0, 100.0])
def test_the_log_transform_expectation_matches_adaptive_quadrature(s: float, dm: float, nats: float) -> None:
    """Gauss-Legendre above the floor's kink f* against scipy's adaptive quadrature split at f*, with
    the GP's mean ``dm`` sds from the kink and E_min worth ``nats`` (tens of nats within one sd)."""
    shift, floor = -0.3, 0.45
    fstar, sigma2 = np.log(floor - shift), floor / (2 * nats)
    m, a = fstar + dm * s, 1 / (2 * sigma2)

    def g(f: float) -> float:
        excess = a * (max(np.exp(f) + shift, floor) - floor)
        return np.exp(-excess - (f - m) ** 2 / (2 * s * s)) / np.sqrt(2 * np.pi) / s

    lo, hi = m - 12 * s, m + 12 * s
    cuts = [lo] + ([fstar] if lo < fstar < hi else []) + [hi]
    ref = sum(integrate.quad(g, u, v, limit=400, epsabs=0, epsrel=1e-11)[0] for u, v in zip(cuts, cuts[1:]))
    got = log_likelihood(np.array([m]), np.array([s * s]), noise_var=sigma2, shift=shift, floor=floor)[0]
    assert got == pytest.approx(np.log(ref) - a * floor, abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(p=arrays(np.float64, 30, elements=st.floats(0.0, 1.0)), theta=arrays(np.float64, (30, 2),
       elements=st.floats(0.0, 1.0)), k=st.integers(0, 29), level=st.sampled_from([0.5, 0.8, 0.9, 0.95]))
def test_a_cell_holding_more_than_the_tail_mass_lies_in_every_interval(p: np.ndarray, theta: np.ndarray, k: int,
                                                                      level: float) -> None:
    """Why the floor keeps the best evaluation inside the intervals: a cell with P > (1 - level)/2
    lies inside every marginal ``level`` interval (each tail holds less than its mass)."""
    w = p + 1e-6
    w = w / w.sum()
    tail = 0.5 * (1 - level)
    w[k] = 0.0
    w = w / w.sum() * (1 - 1.01 * tail) if w.sum() > 0 else w
    w[k] = 1.01 * tail
    P = xr.DataArray(w / w.sum(), dims=("cell",))
    marg = marginals(P, theta, _space(2), level=level)
    assert np.all(marg["lower"].values <= theta[k]) and np.all(theta[k] <= marg["upper"].values)


def _marg(std, lower, upper, prior_std=0.29) -> xr.Dataset:
    n, dims = len(std), ("parameter",)
    return xr.Dataset({"mean": (dims, 0.5 * (np.asarray(lower) + np.asarray(upper))), "std": (dims, np.asarray(std)),
                       "lower": (dims, np.asarray(lower)), "upper": (dims, np.asarray(upper)),
                       "prior_std": (dims, np.full(n, prior_std))}, coords={"parameter": [f"x{i}" for i in range(n)]})


@settings(max_examples=100, deadline=None)
@given(std=arrays(np.float64, 4, elements=st.floats(1e-3, 0.3)), lo=arrays(np.float64, 4, elements=st.floats(0, 1)),
       width=arrays(np.float64, 4, elements=st.floats(0, 0.5)), best=arrays(np.float64, 4, elements=st.floats(0, 1)),
       verified=st.floats(0.0, 1.0))
def test_no_verdict_passes_an_interval_that_excludes_the_best_evaluation(std, lo, width, best, verified) -> None:
    marg = _marg(std, lo, lo + width)
    verdicts, reasons = decide(marg, best_theta=best, verified=verified)
    tol = 1e-9 * (lo + width)                     # decide's relative tolerance for rounding
    inside = (lo - tol <= best) & (best <= lo + width + tol)
    for j, (v, why) in enumerate(zip(verdicts, reasons)):
        assert v == "not identified" or inside[j]
        if not inside[j] and std[j] / 0.29 < 0.8:
            assert "contradicts its evaluations" in why
    assert set(unsupported(marg, best)) == {f"x{j}" for j in range(4) if not inside[j]}


def _valley(x: np.ndarray, centre: float) -> np.ndarray:
    """A 15-D error with a valley a few per cent of the box wide in x4, on a floor (model error) of 0.03."""
    d = x[:, 4] - centre
    return 0.03 * (1 + 0.1 * ((x[:, :4] - 0.5) ** 2).sum(1)) + 30 * d**2 + 0.5 * np.abs(d)


def test_in_15d_the_floor_keeps_the_best_evaluation_inside_the_interval() -> None:
    """The mechanism of the testbed failure without a simulator: 30 evaluations in 15-D (16 spread,
    14 in the valley), σ² = δ E_min / 2 with δ = 0.05. The GP's lengthscale in x4 (0.13-0.3) is
    wider than the valley, so it extrapolates an error below E_min to cells nobody evaluated (the
    box's edge), and the unfloored P piles there, outside the best evaluation's x4. With the floor
    every interval the data narrow (std < 0.8 prior std) holds it."""
    space = _space(15)
    grid = SobolCandidates.for_decoder(Identity(space), n=4096, seed=0)
    outside = {"zero": 0, "best": 0}
    for seed in range(10):
        rng = np.random.default_rng(seed)
        centre = rng.uniform(0.6, 0.95)
        near = grid.points[np.argsort(np.abs(grid.points[:, 4] - centre))[:200]]
        Z = np.vstack([grid.points[rng.choice(grid.size, 16, replace=False)], near[rng.choice(200, 14, replace=False)]])
        E = _valley(Z, centre)
        gp = GPSurrogate(grid.bounds).fit(Z, E)
        pred = gp.predict(grid.points)
        best = Z[np.argmin(E)]
        for floor in outside:
            P = posterior_from_surrogate(gp, grid, config=PosteriorConfig(floor=floor), noise_var=0.025 * E.min(),
                                         prediction=pred)
            m = marginals(P, grid.points, space)
            narrow = {str(n) for n in m["parameter"].values[(m["std"] < 0.8 * m["prior_std"]).values]}
            outside[floor] += len(narrow & set(unsupported(m, best)))
            if floor == "best":
                assert P.attrs["error_floor"] == pytest.approx(E.min())
                assert P.values.max() <= P.values.ravel()[np.argmin(np.abs(grid.points - best).sum(1))] * 1.5
    assert outside["zero"] >= 2          # the failure is real: P contradicted its evaluations
    assert outside["best"] == 0


def test_trust_note_says_why_p_cannot_be_trusted() -> None:
    marg = _marg(std=[0.01, 0.29], lower=[0.6, 0.0], upper=[0.62, 1.0])
    verdicts = decide(marg, best_theta=[0.3, 0.5], verified=0.0)[0]
    note = trust_note(marg, verdicts, best_theta=[0.3, 0.5], verified=0.0, best_mass=0.0)
    assert "contradicts its evaluations" in note and "x0" in note and "x1" not in note
    verdicts = decide(marg, best_theta=[0.61, 0.5], verified=0.1)[0]
    assert verdicts == ["weakly identified", "not identified"]
    note = trust_note(marg, verdicts, best_theta=[0.61, 0.5], verified=0.1, best_mass=0.2)
    assert "GP's guesses" in note and "10%" in note and "20.0%" in note and "x1" not in note
    assert trust_note(marg, ["not identified"] * 2, best_theta=[0.61, 0.5], verified=0.1, best_mass=0.2) == ""
    assert trust_note(marg, verdicts, best_theta=[0.61, 0.5], verified=0.9, best_mass=0.2) == ""


def test_the_floor_is_the_best_error_when_sigma2_is_estimated() -> None:
    class _Fitted:
        errors_ = np.array([0.7, 0.2, 0.4])

    assert error_floor(_Fitted(), PosteriorConfig()) == 0.2                      # "auto", σ² estimated
    assert error_floor(_Fitted(), PosteriorConfig(), noise_known=True) == 0.0    # a known σ² sets the scale
    assert error_floor(_Fitted(), PosteriorConfig(floor="best"), noise_known=True) == 0.2
    assert error_floor(_Fitted(), PosteriorConfig(floor="zero")) == 0.0


def test_floor_option_is_validated() -> None:
    with pytest.raises(BeliefError, match="floor must be one of"):
        PosteriorConfig(floor="median")
