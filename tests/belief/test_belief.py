"""Belief: the posterior as an object (round trip, sampling follows P, determinism, verdicts, validation).

P is built by hand (a Gaussian bump over the cells), no identification run.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from scipy.stats import chisquare

from belief.belief import FORMAT, Belief, default_verdicts
from belief.errors import BeliefError, GridError
from belief.grid import Grid, SobolCandidates, candidates_from_config
from embeddings import REMBO, Identity
from physics.parameters import Parameter, ParameterSpace


def _space(D: int = 2) -> ParameterSpace:
    return ParameterSpace(tuple(Parameter(f"x{i}", "m", 0.5, 0.0, 1.0 + i, description=f"axis {i} (θ_{i})",
                                          minimum=-1.0, strict=bool(i % 2)) for i in range(D)))


def _bump(grid, centre, width) -> np.ndarray:
    """Gaussian bump exp(-|u - centre|^2 / (2 width^2)) over the cells (u: cells in the unit box), normalized."""
    lo, hi = grid.bounds[:, 0], grid.bounds[:, 1]
    u = (grid.points - lo) / (hi - lo)
    w = np.exp(-0.5 * np.sum(((u - np.asarray(centre)) / np.asarray(width)) ** 2, axis=1))
    return w / w.sum()


def _belief(kind: str = "identity", **kw) -> Belief:
    if kind == "rembo":
        dec = REMBO(ParameterSpace.t6(), dim=2, seed=4)
        grid = Grid.for_decoder(dec, points_per_dim=9)
    elif kind == "sobol":
        dec = Identity(ParameterSpace.t6())
        grid = SobolCandidates.for_decoder(dec, n=256, seed=1)
    else:
        dec = Identity(_space())
        grid = Grid.for_decoder(dec, points_per_dim=7)
    P = grid.to_dataarray(_bump(grid, 0.3, kw.pop("width", 0.3)), name="P")
    P.attrs.update({"mode": "likelihood", "noise_var": np.float64(1e-3)})
    return Belief.from_posterior(P, dec, grid, **kw)


def _args(b: Belief) -> dict:
    return {"decoder_config": b.decoder_config, "grid_config": b.grid_config}


@pytest.mark.parametrize("kind", ["identity", "rembo", "sobol"])
def test_round_trip_keeps_everything(kind: str, tmp_path) -> None:
    b0 = _belief(kind)
    D = b0.space.dim
    verdicts = (["identified", "weakly identified", "not identified"] * D)[:D]
    reasons = [f"σ² rule says {j} — ünïcode" for j in range(D - 1)] + [""]
    attrs = {"noise_rule": "ess", "noise_var": np.float64(2e-3), "K": np.int64(7), "warn": None,
             "noise": {"K_eff": 3.5, "segments": ("a", "b")}, "flag": True}
    b = Belief(b0.P, b0.theta, b0.space, **_args(b0), verdicts=verdicts, reasons=reasons, attrs=attrs)
    b.save(tmp_path / "b.nc")
    c = Belief.load(tmp_path / "b.nc")
    assert np.array_equal(c.p, b.p) and c.P.dims == b.P.dims and c.P.attrs == b.P.attrs
    assert all(np.array_equal(c.P[n].values, b.P[n].values) for n in b.P.coords)
    assert np.array_equal(c.theta, b.theta)
    assert c.space == b.space and c.space.parameters == b.space.parameters
    assert c.decoder_config == b.decoder_config and c.grid_config == b.grid_config
    assert c.verdict == tuple(verdicts) and c.reason == tuple(reasons)
    assert c.attrs == b.attrs == {**attrs, "noise_var": 2e-3, "K": 7, "noise": {"K_eff": 3.5, "segments": ["a", "b"]}}
    assert np.array_equal(c.sample(50, seed=3), b.sample(50, seed=3))
    assert c.decoder().config() == b0.decoder_config
    assert np.array_equal(c.decoder().decode(c.grid().points), b.theta)
    xr.testing.assert_identical(c.marginals(), b.marginals())


def test_belief_embeds_as_a_group_of_another_file(tmp_path) -> None:
    b = _belief("rembo")
    path = tmp_path / "result.nc"
    xr.Dataset({"best": ("x", [1.0, 2.0])}, attrs={"format": "other"}).to_netcdf(path, mode="w")
    b.to_dataset().to_netcdf(path, mode="a", group="belief", engine="netcdf4")
    c = Belief.load(path, group="belief")
    assert np.array_equal(c.p, b.p) and c.verdicts == b.verdicts
    assert Belief.from_dataset(b.to_dataset()).attrs == b.attrs
    with pytest.raises(BeliefError, match="not a tensegrid belief"):
        Belief.load(path)
    with pytest.raises(BeliefError, match="not a readable netCDF belief group 'nope'"):
        Belief.load(path, group="nope")


def _counts_test(counts: np.ndarray, p: np.ndarray) -> float:
    """Chi-square p-value of cell counts against P, cells with expected count < 5 pooled into one bin."""
    n = counts.sum()
    small = n * p < 5
    obs, exp = counts[~small], n * p[~small]
    if small.any():
        obs, exp = np.append(obs, counts[small].sum()), np.append(exp, n * p[small].sum())
    return float(chisquare(obs, exp).pvalue)


def test_samples_follow_p() -> None:
    b = _belief("identity", width=0.25)                           # 49 cells
    cells = b.sample_cells(4000, seed=0)
    counts = np.bincount(cells, minlength=b.n_cells)
    assert _counts_test(counts, b.p) > 1e-3
    # the test has power: the same draws are rejected against a P they do not follow
    assert _counts_test(counts, np.full(b.n_cells, 1.0 / b.n_cells)) < 1e-6
    wrong = np.roll(b.p, 3)
    assert _counts_test(counts, wrong) < 1e-6
    # sample() returns the decoded centres of exactly those cells
    assert np.array_equal(b.sample(4000, seed=0), b.theta[cells])


def test_cells_without_mass_are_never_drawn() -> None:
    b0 = _belief("identity")
    p = np.zeros(b0.n_cells)
    p[[3, 10]] = [0.25, 0.75]
    b = Belief(p, b0.theta, b0.space, **_args(b0))
    cells = b.sample_cells(2000, seed=5)
    assert set(np.unique(cells)) == {3, 10} and 0.7 < np.mean(cells == 10) < 0.8
    assert np.array_equal(b.map, b0.theta[10])
    assert b.entropy() == pytest.approx(-(0.25 * np.log(0.25) + 0.75 * np.log(0.75)))


def test_same_seed_same_draws() -> None:
    b = _belief("sobol")
    assert np.array_equal(b.sample(10, seed=1), b.sample(10, seed=1))
    assert np.array_equal(b.sample(10, seed=np.random.default_rng(1)), b.sample(10, seed=1))
    assert not np.array_equal(b.sample(10, seed=1), b.sample(10, seed=2))
    assert b.sample(0, seed=1).shape == (0, 15) and b.sample(3, seed=1).shape == (3, 15)


def test_summaries_agree_with_p() -> None:
    b = _belief("sobol")
    m = b.marginals()
    assert np.allclose(m["mean"].values, b.p @ b.theta) and np.allclose(b.mean, m["mean"].values)
    assert np.array_equal(b.map, b.theta[np.argmax(b.p)]) and np.array_equal(m["map"].values, b.map)
    assert list(m["parameter"].values) == list(b.space.names) and list(m["unit"].values) == list(b.space.units)
    assert set(m.data_vars) >= {"mean", "std", "lower", "upper", "map", "prior_mean", "prior_std", "verdict", "reason"}
    wide, narrow = b.interval(0.9), b.interval(0.5)
    assert wide.shape == (15, 2) and np.array_equal(wide, np.column_stack([m["lower"], m["upper"]]))
    assert np.all(wide[:, 0] <= narrow[:, 0]) and np.all(narrow[:, 1] <= wide[:, 1])
    assert np.array_equal(b.identified, m["identified"].values)
    assert b.verdicts["density"] == (m["verdict"].values[0], m["reason"].values[0])
    uniform = Belief(np.full(b.n_cells, 1.0 / b.n_cells), b.theta, b.space, **_args(b))
    assert uniform.entropy() == pytest.approx(np.log(b.n_cells)) and not uniform.identified.any()
    text = b.summary(truth=b.mean)
    assert "truth" in text and all(n in text for n in b.space.names)
    best = b.mean * 1.01
    lines = b.summary(best=best).splitlines()
    assert lines[0].split()[5] == "best" and "truth" not in lines[0]
    assert [float(line.split()[5]) for line in lines[1:16]] == pytest.approx(best, rel=1e-4)


def test_default_verdicts_follow_the_std_ratio() -> None:
    space = _space(3)
    dec = Identity(space)
    grid = Grid.for_decoder(dec, points_per_dim=15)
    P = grid.to_dataarray(_bump(grid, [0.5, 0.5, 0.5], [0.04, 0.18, 10.0]), name="P")
    b = Belief.from_posterior(P, dec, grid)
    m = b.marginals()
    ratio = m["std"].values / m["prior_std"].values
    assert ratio[0] < 0.5 and 0.5 <= ratio[1] < 0.8 and ratio[2] >= 0.8
    assert b.verdict == ("identified", "weakly identified", "not identified")
    assert all(f"{r:.0%} of its prior spread" in why for r, why in zip(ratio[:2], b.reason[:2], strict=True))
    assert "do not narrow it" in b.reason[2] or f"{ratio[2]:.0%}" in b.reason[2]
    assert list(b.identified) == [True, False, False]
    # a parameter the decoder never varies (prior std 0) is not identified, whatever P says
    theta = b.theta.copy()
    theta[:, 0] = 0.5
    flat = Belief(b.P, theta, space, **_args(b))
    assert flat.verdict[0] == "not identified" and "never varied it" in flat.reason[0]
    assert default_verdicts(flat.marginals())[0][0] == "not identified"


def test_given_verdicts_override_the_default() -> None:
    b = _belief("identity", verdicts=["not identified", "identified"], reasons=["segments disagree", "ok"])
    assert b.verdicts == {"x0": ("not identified", "segments disagree"), "x1": ("identified", "ok")}


def test_grid_rebuilds_from_its_config() -> None:
    g = Grid([[0.0, 1.0], [-2.0, 2.0]], points_per_dim=(3, 5))
    s = SobolCandidates([[0.0, 1.0]] * 3, n=40, seed=7)
    for cells in (g, s):
        again = candidates_from_config(json.loads(json.dumps(cells.config())))
        assert type(again) is type(cells) and np.array_equal(again.points, cells.points)
        assert type(cells).from_config(cells.config()).config() == cells.config()
    with pytest.raises(GridError, match="unknown candidate-set kind 'hex'"):
        candidates_from_config({"kind": "hex"})
    with pytest.raises(GridError, match=r"lacks \['seed'\]"):
        SobolCandidates.from_config({"kind": "sobol", "bounds": [[0.0, 1.0]], "n": 4})
    with pytest.raises(GridError, match="config must be a dict with kind 'grid'"):
        Grid.from_config(s.config())
    with pytest.raises(GridError, match=r"differs from the saved configuration in \['extra'\]"):
        Grid.from_config({**g.config(), "extra": 1})


def _raises(match: str, b: Belief, **changes) -> None:
    kw = {"P": b.P, "theta": b.theta, "space": b.space, **_args(b), **changes}
    with pytest.raises(BeliefError, match=match):
        Belief(kw.pop("P"), kw.pop("theta"), kw.pop("space"), **kw)


def test_constructor_validation_names_the_problem() -> None:
    b = _belief("identity")
    other = Grid([[0.0, 2.0], [0.0, 2.0]], points_per_dim=7).to_dataarray(b.p, name="P")
    _raises("space must be a physics ParameterSpace", b, space=["x0", "x1"])
    _raises("decoder_config must be decoder.config", b, decoder_config={"dim": 2})
    _raises("grid_config must be grid.config", b, grid_config="grid")
    _raises("unknown candidate-set kind", b, grid_config={"kind": "hex"})
    _raises("attrs must be a dict with string keys", b, attrs={1: "a"})
    _raises("attrs must be JSON-able", b, attrs={"f": object()})
    _raises(r"level must lie in \(0, 1\)", b, level=1.0)
    _raises(r"P must be a DataArray over the grid's dims \('z0', 'z1'\)", b, P=b.P.rename({"z0": "a"}))
    _raises("with shape", b, P=b.P.isel(z0=slice(0, 6)))
    _raises("P's coordinate 'z0' differs from the grid's", b, P=other)
    _raises(r"one probability per cell \(49, in cell order\)", b, P=b.p[:-1])
    _raises("P must hold real probabilities", b, P=np.array(["a"] * 49))
    negative = b.p.copy()
    negative[1] += negative[0] + 0.01
    negative[0] = -0.01
    _raises("finite and >= 0 .* 1 negative", b, P=negative)
    _raises("finite and >= 0 .* 1 non-finite", b, P=np.where(np.arange(49) == 5, np.nan, b.p))
    _raises("P must sum to 1", b, P=b.P * 2)
    _raises(r"theta must be finite with shape \(49, 2\)", b, theta=b.theta[:, :1])
    _raises("theta must be finite", b, theta=np.where(b.theta > 0.5, np.inf, b.theta))
    _raises("verdicts given without reasons", b, verdicts=["identified"] * 2)
    _raises("reasons given without verdicts", b, reasons=["a", "b"])
    _raises("one verdict and one reason per parameter", b, verdicts=["identified"], reasons=["a"])
    _raises("verdicts must be among", b, verdicts=["sure", "identified"], reasons=["a", "b"])
    _raises("reasons strings", b, verdicts=["identified"] * 2, reasons=[1, 2])


def test_other_validation_branches(tmp_path) -> None:
    b = _belief("identity")
    dec, grid = b.decoder(), b.grid()
    with pytest.raises(BeliefError, match="P must be an xarray.DataArray"):
        Belief.from_posterior(b.p, dec, grid)
    with pytest.raises(BeliefError, match="the grid has 3 latent dims but the decoder 2"):
        Belief.from_posterior(b.P, dec, Grid([[0.0, 1.0]] * 3, points_per_dim=2))
    for n in (-1, 2.0, True):
        with pytest.raises(BeliefError, match="n must be an integer >= 0"):
            b.sample(n, seed=0)
    with pytest.raises(BeliefError, match="seed must be an int or a numpy.random.Generator"):
        b.sample(3, seed=None)
    with pytest.raises(BeliefError, match=r"truth must have shape \(2,\)"):
        b.summary(truth=[1.0])
    with pytest.raises(BeliefError, match=r"best must have shape \(2,\)"):
        b.summary(best=[1.0, 2.0, 3.0])


def test_loading_what_is_not_a_belief_fails(tmp_path) -> None:
    b = _belief("identity")
    with pytest.raises(BeliefError, match="no belief file"):
        Belief.load(tmp_path / "missing.nc")
    (tmp_path / "junk.nc").write_bytes(b"not a netCDF file at all")
    with pytest.raises(BeliefError, match="not a readable netCDF belief"):
        Belief.load(tmp_path / "junk.nc")
    b.P.to_dataset(name="P").to_netcdf(tmp_path / "other.nc")
    with pytest.raises(BeliefError, match="not a tensegrid belief"):
        Belief.load(tmp_path / "other.nc")
    with pytest.raises(BeliefError, match="not a tensegrid belief"):
        Belief.from_dataset(b.P)
    ds = b.to_dataset()
    assert ds.attrs["format"] == FORMAT == "tensegrid.belief/1"
    with pytest.raises(BeliefError, match=r"lacks \['reason'\]"):
        Belief.from_dataset(ds.drop_vars("reason"))
    with pytest.raises(BeliefError, match="corrupt attribute"):
        Belief.from_dataset(ds.assign_attrs(attrs="{not json"))
    with pytest.raises(BeliefError, match="parameter space cannot be rebuilt"):
        Belief.from_dataset(ds.assign(lower_bound=("parameter", [5.0, 5.0])))


def test_a_grid_that_is_not_grid_config_is_refused() -> None:
    space = ParameterSpace.t6()
    dec = Identity(space)
    grid = SobolCandidates.for_decoder(dec, n=64, seed=1)
    other = SobolCandidates.for_decoder(dec, n=64, seed=2)
    P = grid.to_dataarray(np.full(64, 1 / 64), name="P")
    b = Belief(P, dec.decode(grid.points), space, decoder_config=dec.config(), grid_config=grid.config(), grid=grid)
    assert np.array_equal(b.p, P.values)
    with pytest.raises(BeliefError, match="grid differs from grid_config"):
        Belief(P, dec.decode(grid.points), space, decoder_config=dec.config(), grid_config=grid.config(), grid=other)


def test_overruled_only_weakens_and_keeps_the_rest(tmp_path) -> None:
    """A rule P cannot hold (criticism's "structure") may weaken a verdict, never strengthen it;
    P, θ and the other verdicts stay, and the new reason survives the file."""
    b = _belief("identity", verdicts=["identified", "weakly identified"], reasons=["narrowing: a", "narrowing: b"])
    o = b.overruled({"x0": ("not identified", "structure: hangs on the model")})
    assert o.verdicts == {"x0": ("not identified", "structure: hangs on the model"),
                          "x1": ("weakly identified", "narrowing: b")}
    assert o.rules == ["structure", "narrowing"] and b.verdict[0] == "identified"
    np.testing.assert_array_equal(o.p, b.p)
    np.testing.assert_array_equal(o.interval(), b.interval())
    o.save(tmp_path / "o.nc")
    assert Belief.load(tmp_path / "o.nc").verdicts == o.verdicts
    with pytest.raises(BeliefError, match="only weaken"):
        b.overruled({"x1": ("identified", "structure: no")})
    with pytest.raises(BeliefError, match="x9"):
        b.overruled({"x9": ("not identified", "structure: no")})
