"""identify (Algorithm 1): the push-toy posterior, determinism, failures, batches, budgets, validation."""
from __future__ import annotations

import time
import warnings

import numpy as np
import pytest
import xarray as xr

from belief import (
    BeliefError,
    BudgetError,
    BudgetWarning,
    Grid,
    GridError,
    IdentificationResult,
    ObjectiveError,
    PosteriorConfig,
    SobolCandidates,
    SurrogateConfig,
    credible_mask,
    identify,
)
from embeddings import REMBO, Identity
from belief.grid import CandidateSet
from physics.errors import ContractError, ParameterError, PhysicsError
from physics.objective import FunctionObjective
from physics.parameters import ParameterSpace
from physics.push import PushObjective, push_space

HIST_VARS = ("z", "theta", "error", "status", "cell", "batch")


def _same_history(a: xr.Dataset, b: xr.Dataset) -> bool:
    return all(np.array_equal(a[v].values, b[v].values, equal_nan=(v in ("error", "z", "theta")))
               for v in HIST_VARS)


@pytest.fixture(scope="module")
def push_run():
    from physics.push import PushObjective, generate_push_data

    truth = np.array([1.0, 0.4])
    J, S = generate_push_data(truth, n=8, noise_std=0.05, seed=0)
    obj = PushObjective(J, S, noise_std=0.05)
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=41)
    res = identify(obj, dec, grid, budget=40, seed=0, progress=False)
    return res, obj, dec, grid, truth


def test_push_truth_lies_in_the_90_percent_region_which_follows_the_ridge(push_run) -> None:
    res, obj, dec, grid, truth = push_run
    P = res.posterior.values.ravel()
    mask = credible_mask(P, level=0.9)
    assert mask[grid.nearest(dec.encode(truth))[0]]
    theta = dec.decode(grid.points)
    ridge = theta[:, 0] ** 2 * theta[:, 1] / (truth[0] ** 2 * truth[1])
    # most of the mass sits near the ridge m^2 mu = const ...
    assert P[np.abs(ridge - 1) < 0.15].sum() > 0.7
    # ... and spreads along it: the region spans a wide range of m (non-identifiable direction)
    assert np.ptp(theta[mask, 0]) > 0.4
    # while the region is a small part of the box
    assert mask.mean() < 0.25
    # the best evaluation explains the data about as well as the truth
    assert res.best_error < 3 * obj(truth)


def test_result_contents(push_run) -> None:
    res, obj, dec, grid, truth = push_run
    h = res.history
    assert h.sizes["evaluation"] == 40 and set(h["status"].values) == {"ok"}
    assert len(set(h["cell"].values.tolist())) == 40  # every cell at most once
    np.testing.assert_array_equal(h["theta"].values, dec.decode(h["z"].values))
    assert res.best_error == pytest.approx(np.nanmin(h["error"].values))
    np.testing.assert_allclose(res.best_theta.values, h["theta"].values[np.nanargmin(h["error"].values)])
    m = res.marginals
    assert list(m["parameter"].values) == ["m", "mu"]
    assert np.all(m["lower"] <= m["mean"]) and np.all(m["mean"] <= m["upper"])
    assert res.config["stopped"] == "budget" and res.config["noise_var"] == pytest.approx(0.0025)
    assert "identified" in res.summary()
    region = res.credible_region(level=0.9)
    assert region.dims == res.posterior.dims and region.dtype == bool
    assert float(res.posterior.where(region).sum()) >= 0.9


def test_save_load_roundtrip(push_run, tmp_path) -> None:
    res = push_run[0]
    res.save(tmp_path / "r.nc")
    back = IdentificationResult.load(tmp_path / "r.nc")
    xr.testing.assert_identical(back.posterior.drop_attrs(), res.posterior.drop_attrs())
    assert _same_history(back.history, res.history)
    assert back.marginals["identified"].dtype == bool
    xr.testing.assert_allclose(back.marginals, res.marginals)
    assert back.best_error == res.best_error and back.config == res.config
    with pytest.raises(BeliefError, match="no result file"):
        IdentificationResult.load(tmp_path / "missing.nc")


def test_same_seed_same_result_other_seed_other_result(push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=21)
    a = identify(obj, dec, grid, budget=12, seed=3, progress=False)
    b = identify(obj, dec, grid, budget=12, seed=3, progress=False)
    c = identify(obj, dec, grid, budget=12, seed=4, progress=False)
    assert _same_history(a.history, b.history) and np.array_equal(a.posterior.values, b.posterior.values)
    assert not np.array_equal(a.history["cell"].values, c.history["cell"].values)


def test_random_method_is_seeded_and_distinct(push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=11)
    a = identify(obj, dec, grid, budget=20, seed=1, proposer="random", progress=False)
    b = identify(obj, dec, grid, budget=20, seed=1, proposer="random", progress=False)
    assert _same_history(a.history, b.history)
    assert len(set(a.history["cell"].values.tolist())) == 20


def test_failed_evaluations_are_recorded_not_fatal(push_problem) -> None:
    obj, _ = push_problem(fail_above=1.2)
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=21)
    res = identify(obj, dec, grid, budget=20, seed=0, progress=False)
    h = res.history
    failed = h["status"].values == "diverged"          # PushObjective's fail_above raises PhysicsError
    assert failed.any() and (~failed).any() and set(h["status"].values) == {"ok", "diverged"}
    assert np.all(np.isnan(h["error"].values[failed])) and np.all(h["theta"].values[failed, 0] > 1.2)
    assert all(msg for msg in h["message"].values[failed])  # every failure says why
    P = res.posterior.values.ravel()
    assert np.all(P[h["cell"].values[failed]] == 0) and P.sum() == pytest.approx(1.0)
    imp = identify(obj, dec, grid, budget=20, seed=0, progress=False, surrogate=SurrogateConfig(impute_failed=True))
    assert (imp.history["status"].values == "diverged").any()


def test_nan_errors_are_failed_evaluations(push_problem) -> None:
    obj, _ = push_problem()

    def nan_when_heavy(theta: np.ndarray) -> float:
        return float("nan") if theta[0] > 1.2 else obj(theta)

    dec = Identity(obj.space)
    res = identify(nan_when_heavy, dec, Grid.for_decoder(dec, points_per_dim=21), budget=15, seed=0,
                   posterior=PosteriorConfig(noise_var=0.0025), progress=False)
    failed = res.history["status"].values == "failed"
    assert failed.any()
    assert all("not one finite value" in m for m in res.history["message"].values[failed])


def test_all_failed_raises_objective_error(push_problem) -> None:
    obj, _ = push_problem()

    def always_diverges(theta: np.ndarray) -> float:
        raise PhysicsError("diverged")

    dec = Identity(obj.space)
    with pytest.raises(ObjectiveError, match="all 6 evaluations failed"):
        identify(always_diverges, dec, Grid.for_decoder(dec, points_per_dim=5), budget=6, seed=0,
                 progress=False)


def test_batches_with_evaluate_batch_or_threads_give_the_same_history(push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=21)
    a = identify(obj, dec, grid, budget=14, q=3, seed=0, progress=False, posterior=None)

    def plain(theta: np.ndarray) -> float:
        return obj(theta)

    b = identify(FunctionObjective(plain, obj.space, workers=2), dec, grid, budget=14, q=3, seed=0, progress=False,
                 posterior=None)
    assert _same_history(a.history, b.history)
    assert a.posterior is None and a.marginals is None
    assert a.history["batch"].values.tolist() == [0] * 5 + [1] * 3 + [2] * 3 + [3] * 3


def test_time_budget_stops_early(push_problem) -> None:
    obj, _ = push_problem()

    def slow(theta: np.ndarray) -> float:
        time.sleep(0.05)
        return obj(theta)

    dec = Identity(obj.space)
    res = identify(slow, dec, Grid.for_decoder(dec, points_per_dim=21), time_budget=0.4, seed=0,
                   posterior=PosteriorConfig(noise_var=0.0025), progress=False)
    assert res.config["stopped"] == "time" and 2 <= res.n_evaluations <= 9


def test_callback_receives_updated_posterior_and_minimizer_mode(push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    seen: list[tuple[int, float]] = []
    res = identify(obj, dec, Grid.for_decoder(dec, points_per_dim=21), budget=9, n_init=5, seed=0,
                   posterior="minimizer", progress=False,
                   callback=lambda n, P: seen.append((n, float(P.sum()))))
    assert [n for n, _ in seen] == [5, 6, 7, 8] and all(abs(s - 1) < 1e-12 for _, s in seen)
    assert res.posterior.attrs["mode"] == "minimizer"


def test_rembo_on_sobol_candidates_in_15d(tmp_path) -> None:
    space = ParameterSpace.t6()
    nominal = space.nominal

    def quad(theta: np.ndarray) -> float:
        return float(np.sum(((theta - nominal) / (space.upper - space.lower)) ** 2))

    dec = REMBO(space, dim=3, seed=0)
    res = identify(quad, dec, Grid.for_decoder(dec, points_per_dim=9), budget=12, seed=0,
                   posterior="minimizer", progress=False)
    assert res.marginals.sizes["parameter"] == 15
    full = Identity(space)
    res2 = identify(quad, full, SobolCandidates.for_decoder(full, n=2000, seed=0), budget=12, seed=0,
                    posterior="minimizer", progress=False)
    assert res2.posterior.dims == ("cell",)
    res2.save(tmp_path / "sobol.nc")
    back = IdentificationResult.load(tmp_path / "sobol.nc")
    assert back.posterior.dims == ("cell",) and "z14" in back.posterior.coords
    assert np.array_equal(back.posterior.values, res2.posterior.values)


class _EmptyGrid(CandidateSet):
    """A candidate set without cells (the contract allows n = 0; identify refuses it)."""

    bounds = np.array([[0.0, 1.0], [0.0, 1.0]])
    _points = np.zeros((0, 2))
    dims = ("cell",)

    def to_dataarray(self, values, *, name=None):  # pragma: no cover - never reached
        raise AssertionError

    def config(self):  # pragma: no cover
        return {"kind": "empty"}

    @classmethod
    def from_config(cls, config):  # pragma: no cover
        return cls()


def test_validation(push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=5)
    run = lambda **kw: identify(**{"objective": obj, "decoder": dec, "grid": grid, "budget": 5, "seed": 0,  # noqa: E731
                                   "progress": False, **kw})
    cases = [
        (BudgetError, "budget must be >= 1", {"budget": 0}),
        (BudgetError, "exceeds the 25 grid cells", {"budget": 26}),
        (BudgetError, "budget must be an integer", {"budget": 2.5}),
        (BudgetError, "both are None", {"budget": None}),
        (BudgetError, "time_budget must be a positive", {"time_budget": -1.0}),
        (BudgetError, "q \\(cells per batch\\)", {"q": 0}),
        (BudgetError, "n_init >= 2", {"n_init": 1}),
        (BeliefError, "proposer must be one of", {"proposer": "grid"}),
        (BeliefError, "proposer must be one of .* or a belief.Proposer", {"proposer": object()}),
        (BeliefError, "seed must be an integer", {"seed": 1.5}),
        (BeliefError, "posterior must be 'likelihood'", {"posterior": "bayes"}),
        (GridError, "grid is empty", {"grid": _EmptyGrid()}),
        (GridError, "grid has 3 latent dimensions", {"grid": Grid(np.tile([0.0, 1.0], (3, 1)), points_per_dim=3)}),
        (GridError, "leave the decoder's latent box", {"grid": Grid([[0.0, 2.0], [0.0, 1.0]], points_per_dim=5)}),
        (GridError, "must be a belief.grid.CandidateSet", {"grid": object()}),
        (BeliefError, "differs from the objective", {"decoder": Identity(push_space(mass=(0.4, 1.5)))}),
        (BeliefError, "an embeddings.Decoder", {"decoder": object()}),
        (ContractError, "must be a physics.objective.Objective or a function", {"objective": 3.0}),
    ]
    for exc, match, kw in cases:
        with pytest.raises(exc, match=match):
            run(**kw)
    for gone in ("method", "space", "workers", "noise_var", "posterior_config", "impute_failed"):
        with pytest.raises(TypeError, match=gone):          # one source per option: these are config fields now
            run(**{gone: None})
    with pytest.raises(ParameterError, match="pass space="):        # a preset has no decoder to take it from
        identify(lambda th: 0.0, budget=5, seed=0, preset="bo", progress=False)
    with pytest.raises(BeliefError, match="space= and workers= wrap a plain function"):
        identify(obj, budget=5, seed=0, preset="bo", space=obj.space, progress=False)
    with pytest.raises(ContractError, match="scalar error, got an array of shape"):
        identify(lambda th: np.ones(3), dec, grid, budget=5, seed=0, progress=False)
    with pytest.raises(ContractError, match="got str"):
        identify(lambda th: "bad", dec, grid, budget=5, seed=0, progress=False)


def test_streamed_rows_keep_statuses_and_parts(push_problem) -> None:
    """evaluate_batch's rows are journalled as they stream through on_result (the physics.objective
    contract), with their segment errors; a row reported "ok" with a non-finite error becomes "failed"."""
    obj, _ = push_problem()

    class Streaming(PushObjective):
        def evaluate_batch(self, thetas, *, on_result=None):
            for k in reversed(range(len(thetas))):
                if k == 0:
                    on_result(k, float("nan"), "ok", 0.5, "", np.full(len(obj.segments), np.nan))
                elif k == 1:
                    on_result(k, float("nan"), "diverged", 0.5, "PhysicsError: exploded",
                              np.full(len(obj.segments), np.nan))
                else:
                    p = obj.evaluate_parts(thetas[k])
                    on_result(k, float(p.sum()), "ok", 0.5, "", p)

    streaming = Streaming(obj.impulses, obj.observed, noise_std=obj.noise_std)
    dec = Identity(obj.space)
    res = identify(streaming, dec, Grid.for_decoder(dec, points_per_dim=11), budget=5, n_init=5, seed=0,
                   progress=False, posterior=None)
    h = res.history
    assert sorted(h["status"].values.tolist()) == ["diverged", "failed", "ok", "ok", "ok"]
    failed = h["status"].values == "failed"
    assert "non-finite" in str(h["message"].values[failed][0])
    ok = h["status"].values == "ok"
    np.testing.assert_allclose(h["parts"].values[ok].sum(axis=1), h["error"].values[ok])
    assert np.isnan(h["parts"].values[~ok]).all()


def test_a_budget_within_the_initial_design_warns_that_bo_never_runs(push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=11)
    with pytest.warns(BudgetWarning, match="budget=5 is no more than the initial design of 5 cells"):
        identify(obj, dec, grid, budget=5, seed=0, progress=False, posterior=None)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BudgetWarning)
        identify(obj, dec, grid, budget=6, seed=0, progress=False, posterior=None)      # one BO step: no warning
        identify(obj, dec, grid, budget=5, seed=0, progress=False, posterior=None, proposer="random")
