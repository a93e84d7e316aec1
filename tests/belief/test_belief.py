"""Belief: the posterior as an object (round trip, sampling, decoder, verdicts)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chisquare

from belief.belief import Belief
from belief.errors import BeliefError
from belief.grid import Grid, SobolCandidates
from embeddings import REMBO, EmbeddingError, Identity, decoder_from_config
from physics.parameters import ParameterSpace


def _bump(grid, centre, width=0.15) -> np.ndarray:
    lo, hi = grid.bounds[:, 0], grid.bounds[:, 1]
    u = (grid.points - lo) / (hi - lo)
    w = np.exp(-0.5 * np.sum(((u - centre) / width) ** 2, axis=1))
    return w / w.sum()


def _belief(kind: str) -> Belief:
    space = ParameterSpace.t6()
    if kind == "rembo":
        dec = REMBO(space, dim=2, seed=4)
        grid = Grid.for_decoder(dec, points_per_dim=9)
    elif kind == "sobol":
        dec = Identity(space)
        grid = SobolCandidates.for_decoder(dec, n=256, seed=1)
    else:
        from physics.push import push_space
        dec = Identity(push_space())
        grid = Grid.for_decoder(dec, points_per_dim=7)
    P = grid.to_dataarray(_bump(grid, 0.3), name="P")
    return Belief.from_posterior(P, dec, grid, attrs={"noise_rule": "ess", "noise_var": 1e-3})


@pytest.mark.parametrize("kind", ["identity", "rembo", "sobol"])
def test_round_trip_keeps_everything(kind: str, tmp_path) -> None:
    b = _belief(kind)
    b.save(tmp_path / "b.nc")
    c = Belief.load(tmp_path / "b.nc")
    assert np.array_equal(c.p, b.p) and c.P.dims == b.P.dims
    assert np.array_equal(c.theta, b.theta)
    assert c.space == b.space
    assert c.decoder_config == b.decoder_config and c.grid_config == b.grid_config
    assert c.verdict == b.verdict and c.reason == b.reason and c.attrs == b.attrs
    assert np.array_equal(c.sample(50, seed=3), b.sample(50, seed=3))
    assert np.array_equal(c.decoder().decode(c.grid().points), b.theta)


def test_samples_follow_p() -> None:
    b = _belief("identity")                                   # 49 cells
    draws = b.sample(20000, seed=0)
    cells = {tuple(t): k for k, t in enumerate(b.theta)}
    counts = np.bincount([cells[tuple(t)] for t in draws], minlength=b.p.size)
    keep = b.p * 20000 >= 5
    expected = b.p[keep] / b.p[keep].sum() * counts[keep].sum()
    assert chisquare(counts[keep], expected).pvalue > 1e-3
    wrong = np.roll(b.p, 3)[keep]                              # a P the draws do not follow
    assert chisquare(counts[keep], wrong / wrong.sum() * counts[keep].sum()).pvalue < 1e-6


def test_same_seed_same_draws_and_summaries() -> None:
    b = _belief("sobol")
    assert np.array_equal(b.sample(10, seed=1), b.sample(10, seed=1))
    assert not np.array_equal(b.sample(10, seed=1), b.sample(10, seed=2))
    m = b.marginals()
    assert np.allclose(m["mean"].values, b.mean)
    assert np.array_equal(b.map, b.theta[np.argmax(b.p)])
    assert b.interval().shape == (15, 2) and np.all(b.interval()[:, 0] <= b.interval()[:, 1])
    assert set(m["verdict"].values) <= {"identified", "weakly identified", "not identified"}
    assert "truth" in b.summary(truth=b.mean)


def test_validation_errors_name_the_problem(tmp_path) -> None:
    b = _belief("identity")
    with pytest.raises(BeliefError, match="sum to 1"):
        Belief(b.P * 2, b.theta, b.space, decoder_config=b.decoder_config, grid_config=b.grid_config)
    with pytest.raises(BeliefError, match="theta must have shape"):
        Belief(b.P, b.theta[:, :1], b.space, decoder_config=b.decoder_config, grid_config=b.grid_config)
    with pytest.raises(BeliefError, match="verdicts must be among"):
        Belief(b.P, b.theta, b.space, decoder_config=b.decoder_config, grid_config=b.grid_config,
               verdicts=["sure", "sure"], reasons=["", ""])
    with pytest.raises(BeliefError, match="one verdict and one reason per parameter"):
        Belief(b.P, b.theta, b.space, decoder_config=b.decoder_config, grid_config=b.grid_config,
               verdicts=["identified"], reasons=[""])
    with pytest.raises(BeliefError, match="n must be an integer"):
        b.sample(-1, seed=0)
    with pytest.raises(BeliefError, match="no belief file"):
        Belief.load(tmp_path / "missing.nc")
    b.P.to_dataset(name="P").to_netcdf(tmp_path / "other.nc")
    with pytest.raises(BeliefError, match="not a tensegrid belief"):
        Belief.load(tmp_path / "other.nc")


def test_decoder_registry_rebuilds_and_refuses() -> None:
    space = ParameterSpace.t6()
    r = REMBO(space, dim=3, seed=2)
    assert np.array_equal(decoder_from_config(r.config(), space).A, r.A)
    with pytest.raises(EmbeddingError, match="unknown decoder kind"):
        decoder_from_config({"kind": "vae"}, space)
    with pytest.raises(EmbeddingError, match="differs from the saved configuration"):
        decoder_from_config({**r.config(), "lower": [0.0] * 15}, space)
