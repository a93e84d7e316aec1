"""Any sampling rate a motion-capture system produces: the physics step, the regular clock, --dt, the loader fuzzed.

The identification test makes the same motion (same θ, same controller) at 100, 120 and 240 Hz,
jitters and drops frames of the fast ones, and identifies two parameters on each: the answers
must agree within their intervals.
"""
from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from physics import FlopController, ModelOptions, ParameterSpace, StateEstimator, TrajectoryObjective, simulate
from physics.errors import StepSizeError, TensegridError, TimestampError, TrajectoryFormatError
from physics.predictor import dt_option, physics_step
from physics.trajectory import TIMESTAMP_TOLERANCE, load_trajectory, regular_clock, validate_trajectory

NAMES = ("stiffnessActive", "radius")
FULL = ParameterSpace.t6()
SUB = ParameterSpace.from_parameters([FULL[n] for n in NAMES])
TRUTH = FULL.replace(None, **dict(zip(NAMES, SUB.from_unit([0.62, 0.37]), strict=True)))
POINTS = 15


def _motion(rate: float, duration: float = 1.0) -> xr.Dataset:
    """The same flop at TRUTH recorded at ``rate`` Hz, positions only (as motion capture gives them)."""
    ds = simulate(TRUTH, controller=FlopController(heading=0.0), duration=duration, settle=1.0, sample_rate=rate)
    return ds.drop_vars("velocities")


def _jitter(ds: xr.Dataset, size: float, seed: int) -> xr.Dataset:
    shift = np.random.default_rng(seed).uniform(-size, size, ds.sizes["time"])
    return ds.assign_coords(time=("time", ds["time"].values + shift, ds["time"].attrs))


def _drop(ds: xr.Dataset, rows: list[int]) -> xr.Dataset:
    """``ds`` without the samples ``rows``: their timestamps are missing from the clock."""
    return ds.isel(time=np.setdiff1d(np.arange(ds.sizes["time"]), rows))


def _nan_rows(ds: xr.Dataset, rows: list[int]) -> xr.Dataset:
    nodes = ds["nodes"].values.copy()
    nodes[rows] = np.nan
    return ds.assign(nodes=ds["nodes"].copy(data=nodes))


# ---------------------------------------------------------------------------------------------- the physics step
@pytest.mark.parametrize("rate, steps", [(100, 10), (120, 9), (200, 5), (240, 5), (1000, 1), (2000, 1)])
def test_the_physics_step_divides_the_interval_and_is_at_most_1_ms(rate: float, steps: int) -> None:
    dt = physics_step(1.0 / rate)
    assert dt <= 1e-3 and (1.0 / rate) / dt == pytest.approx(steps, abs=1e-9)
    assert physics_step(0.01) == ModelOptions().dt       # exactly the default at 100 Hz


@pytest.mark.parametrize("rate", [120.0, 200.0, 240.0])
def test_simulate_and_evaluate_at_rates_that_are_not_whole_milliseconds(rate: float) -> None:
    ds = _motion(rate, duration=0.2)
    assert ds.attrs["physics_dt"] == pytest.approx(physics_step(1.0 / rate))
    with TrajectoryObjective(ds, n_workers=0) as E:
        assert E.model_options[0].dt == ds.attrs["physics_dt"] and np.isfinite(E(TRUTH))


def test_a_given_dt_must_divide_the_interval(tmp_path: Path) -> None:
    ds = _motion(120.0, duration=0.2)
    with pytest.raises(StepSizeError, match="not a whole number of physics steps") as info:
        TrajectoryObjective(ds, options=ModelOptions(dt=0.001))
    assert "\n" not in str(info.value) and isinstance(info.value, TrajectoryFormatError)
    assert dt_option(None, [ds]) is None
    assert dt_option(1 / 1200, [ds], name="--dt").dt == pytest.approx(1 / 1200)
    for bad in (0.0, -1e-3, float("nan"), 0.02):
        with pytest.raises(StepSizeError, match=r"--dt must be a physics step in \(0, 0.01\] s"):
            dt_option(bad, [ds], name="--dt")
    with pytest.raises(StepSizeError, match="--dt 0.001 s on trajectory 0: the sampling interval"):
        dt_option(0.001, [ds], name="--dt")


@pytest.mark.parametrize("command", ["identify", "diagnose"])
def test_the_dt_option_is_checked_before_anything_runs_or_is_written(tmp_path: Path, command: str, capsys) -> None:
    from physics.cli import main

    data = tmp_path / "a120.nc"
    _motion(120.0, duration=0.5).to_netcdf(data)
    out = tmp_path / "out"
    for dt, says in (("0.001", "not a whole number of physics steps"), ("-0.001", "must be a physics step")):
        assert main([command, str(data), "--dt", dt, "--out", str(out), "--budget", "20", "--no-progress"]) == 2
        err = capsys.readouterr().err.strip()
        assert "--dt" in err and says in err and len(err.splitlines()) == 1, err
        assert not out.exists()


# ---------------------------------------------------------------------------------------------- the regular clock
def test_jitter_within_the_tolerance_is_snapped_onto_the_clock(tmp_path: Path) -> None:
    clean = _motion(240.0, duration=0.3)
    jittered = _jitter(clean, 0.2e-3, seed=1)            # ±0.2 ms: 5 % of 4.17 ms
    jittered.to_netcdf(tmp_path / "jitter.nc")
    back = load_trajectory(tmp_path / "jitter.nc")
    steps = np.diff(back["time"].values)
    np.testing.assert_allclose(steps, 1.0 / 240.0, rtol=1e-12)     # whole hertz, exactly
    assert abs(float(back["time"][0])) < 0.2e-3
    np.testing.assert_array_equal(back["nodes"].values, clean["nodes"].values)
    assert "240 Hz clock" in back.attrs["clock"]


def test_a_missing_timestamp_is_a_nan_row_not_an_error(tmp_path: Path) -> None:
    clean = _motion(120.0, duration=0.3)
    _drop(_jitter(clean, 0.1e-3, seed=2), [5, 17, 18]).to_netcdf(tmp_path / "dropped.nc")
    back = load_trajectory(tmp_path / "dropped.nc")
    assert back.sizes["time"] == clean.sizes["time"]
    missing = ~np.isfinite(back["nodes"].values).all(axis=(1, 2))
    np.testing.assert_array_equal(np.flatnonzero(missing), [5, 17, 18])
    np.testing.assert_array_equal(back["nodes"].values[~missing], clean["nodes"].values[~missing])
    assert "3 missing timestamps became NaN rows" in back.attrs["clock"]
    # the stored format itself stays strict: the in-memory validator names the fix
    with pytest.raises(TrajectoryFormatError, match="uniformly sampled.*regular_clock"):
        validate_trajectory(_drop(clean, [5]))


def test_jitter_beyond_the_tolerance_is_a_typed_one_line_error(tmp_path: Path) -> None:
    clean = _motion(100.0, duration=0.3)
    times = clean["time"].values.copy()
    times[7] += 0.3 * 0.01                                   # one timestamp 30 % of the interval off
    clean.assign_coords(time=("time", times)).to_netcdf(tmp_path / "late.nc")
    with pytest.raises(TimestampError, match=r"timestamp 7 .* only deviations up to 25% are snapped") as info:
        load_trajectory(tmp_path / "late.nc")
    assert "\n" not in str(info.value) and "late.nc" in str(info.value)
    assert TIMESTAMP_TOLERANCE == 0.25
    assert regular_clock(clean.assign_coords(time=("time", times)), tolerance=0.35).sizes["time"] == 31


def test_a_clock_with_more_missing_ticks_than_samples_is_refused() -> None:
    ds = _motion(100.0, duration=0.2)
    steps = np.r_[np.full(11, 0.01), np.full(9, 0.05)]     # the median step is 0.01 s: 36 of 57 ticks empty
    sparse = ds.assign_coords(time=("time", np.r_[0.0, np.cumsum(steps)]))
    with pytest.raises(TimestampError, match="more missing than present"):
        regular_clock(sparse)


# ---------------------------------------------------------------------------------------------- identification
class _Held:
    """The T6 error on the two parameters NAMES, the other 13 held at their nominal values."""

    def __init__(self, objective: TrajectoryObjective) -> None:
        self.objective, self.space = objective, SUB
        self._index = [FULL.index(n) for n in NAMES]

    def _lift(self, thetas: np.ndarray) -> np.ndarray:
        rows = np.atleast_2d(np.asarray(thetas, float))
        out = np.tile(FULL.nominal, (len(rows), 1))
        out[:, self._index] = rows
        return out

    segments = property(lambda self: self.objective.segments)
    n_observations = property(lambda self: self.objective.n_observations)
    noise_var = property(lambda self: None)
    noise_floor = property(lambda self: self.objective.noise_floor)

    def __call__(self, theta: np.ndarray) -> float:
        return self.objective(self._lift(theta)[0])

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        return self.objective.evaluate_parts(self._lift(theta)[0])

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: Callable[..., None] | None = None) -> Any:
        return self.objective.evaluate_batch(self._lift(thetas), parallel=False, on_result=on_result)

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        return self.objective.residuals(self._lift(theta)[0])

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        return self.objective.residuals_batch(self._lift(thetas), parallel=False)

    def fingerprint(self) -> dict:
        return {"kind": "held", "names": list(NAMES), **self.objective.fingerprint()}


def _identify(path: Path) -> xr.Dataset:
    from belief import Grid, PosteriorConfig, identify
    from embeddings import Identity

    # noise-free positions: the backward difference's smaller truncation error (no noise for it to carry)
    with TrajectoryObjective(load_trajectory(path), loss="squared", n_workers=0,
                             states=StateEstimator(method="backward")) as E:
        decoder = Identity(SUB)
        # data from this very model: the discrepancy floor for no model error (docs/identification.md)
        result = identify(_Held(E), decoder, Grid.for_decoder(decoder, points_per_dim=POINTS), budget=20, seed=0,
                          progress=False, posterior=PosteriorConfig(discrepancy=0.05))
    return result.marginals


@pytest.fixture(scope="module")
def answers(tmp_path_factory: pytest.TempPathFactory) -> dict[str, xr.Dataset]:
    folder = tmp_path_factory.mktemp("rates")
    made = {
        "100 Hz": _motion(100.0),
        "120 Hz, jitter, 3 timestamps missing": _drop(_jitter(_motion(120.0), 0.2e-3, seed=3), [30, 31, 77]),
        "240 Hz, jitter, NaN rows, a timestamp missing": _drop(_nan_rows(_jitter(_motion(240.0), 0.2e-3, seed=4),
                                                                         [40, 41, 150]), [200]),
    }
    out = {}
    for k, (name, ds) in enumerate(made.items()):
        ds.to_netcdf(folder / f"{k}.nc")
        out[name] = _identify(folder / f"{k}.nc")
    return out


def test_faster_jittered_data_with_dropped_frames_identify_to_the_same_answer(answers: dict[str, xr.Dataset]) -> None:
    step = (SUB.upper - SUB.lower) / (POINTS - 1)               # the grid's resolution per parameter
    reference = answers["100 Hz"]
    for name, m in answers.items():
        for j, par in enumerate(NAMES):
            mine, ref = m.sel(parameter=par), reference.sel(parameter=par)
            lo, hi = float(mine["lower"]) - step[j], float(mine["upper"]) + step[j]
            assert float(mine["upper"]) - float(mine["lower"]) < 0.5 * (SUB.upper[j] - SUB.lower[j]), (name, par)
            assert lo <= float(ref["mean"]) <= hi, (name, par, m.to_dataframe())
            assert float(ref["lower"]) - step[j] <= float(mine["mean"]) <= float(ref["upper"]) + step[j], (name, par)
            assert lo <= TRUTH[FULL.index(par)] <= hi, (name, par)


# ---------------------------------------------------------------------------------------------- the loader, fuzzed
def _base(n: int) -> xr.Dataset:
    rng = np.random.default_rng(n)
    from physics.trajectory import make_trajectory
    return make_trajectory(np.arange(n) * 0.01, rng.normal(size=(n, 12, 3)), np.full((n, 24), 0.9))


_TIME_AXES: dict[str, Callable[[np.ndarray, np.random.Generator], np.ndarray]] = {
    "uniform": lambda t, rng: t,
    "milliseconds": lambda t, rng: t * 1000.0,
    "jitter": lambda t, rng: t + rng.uniform(-0.6, 0.6, t.size) * 0.01 * rng.uniform(),
    "shuffled": lambda t, rng: rng.permutation(t),
    "duplicate": lambda t, rng: np.r_[t[:1], t[:-1]],
    "nan": lambda t, rng: np.where(np.arange(t.size) == t.size // 2, np.nan, t),
    "sparse": lambda t, rng: t ** 3 * 100.0,
    "constant": lambda t, rng: np.zeros_like(t),
}


@st.composite
def _datasets(draw: st.DrawFn) -> xr.Dataset:
    n = draw(st.integers(1, 12))
    rng = np.random.default_rng(draw(st.integers(0, 2**16)))
    ds = _base(max(n, 2)).isel(time=slice(0, n))
    if draw(st.booleans()):                          # dropped frames: rows missing from the clock
        ds = ds.isel(time=np.flatnonzero(rng.uniform(size=n) < 0.8))
    axis = draw(st.sampled_from(["uniform", "jitter"] * 3 + sorted(_TIME_AXES)))   # mostly loadable
    time = _TIME_AXES[axis](ds["time"].values.copy(), rng)
    ds = ds.assign_coords(time=("time", time, {"units": draw(st.sampled_from(["s", "ms", "seconds"]))}))
    nodes = ds["nodes"].values.copy()
    fill = draw(st.sampled_from(["none", "none", "some nan", "some nan", "all nan", "inf"]))
    if fill != "none" and nodes.size:
        mask = rng.uniform(size=nodes.shape) < (1.0 if fill == "all nan" else 0.3)
        nodes[mask] = np.inf if fill == "inf" else np.nan
    units = draw(st.sampled_from(["m", "m", "m", "metres", "mm", "", 5, [1.0, 2.0]]))
    ds = ds.assign(nodes=(("time", "node", "axis"), nodes, {"units": units}))
    shape = draw(st.sampled_from(["as is"] * 4 + ["11 nodes", "2 axes", "20 cables", "no controls", "transposed"]))
    if shape == "11 nodes":
        ds = ds.isel(node=slice(0, 11))
    elif shape == "2 axes":
        ds = ds.isel(axis=slice(0, 2))
    elif shape == "20 cables":
        ds = ds.isel(cable=slice(0, 20))
    elif shape == "no controls":
        ds = ds.drop_vars("controls")
    elif shape == "transposed":
        ds = ds.transpose("axis", "node", "time", "cable")
    return ds


def _odd_units(units: object) -> xr.Dataset:
    ds = _base(4)
    return ds.assign(nodes=ds["nodes"].assign_attrs(units=units))


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_datasets(), st.booleans())
@example(_odd_units([1.0, 2.0]), True)                  # an array attribute once written to netCDF
@example(_odd_units(5), True)
@example(_base(6).assign_coords(time=("time", np.arange(6) * 0.01 + np.array([0, 4, 0, -4, 0, 0]) * 1e-3)), False)
def test_the_loader_loads_or_raises_a_typed_error(ds: xr.Dataset, through_file: bool) -> None:
    try:
        if through_file:
            with tempfile.TemporaryDirectory() as folder:
                path = os.path.join(folder, "fuzz.nc")
                ds.to_netcdf(path)
                out = load_trajectory(path)
        else:
            out = validate_trajectory(regular_clock(ds))
    except TensegridError as exc:
        assert str(exc) and "\n" not in str(exc)
        return
    t = out["time"].values
    assert out["nodes"].dims == ("time", "node", "axis") and out["nodes"].shape[1:] == (12, 3)
    assert t.size >= 2 and np.all(np.diff(t) > 0) and np.ptp(np.diff(t)) <= 1e-6 * max(1.0, float(np.mean(np.diff(t))))
