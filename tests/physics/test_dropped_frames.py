"""Rollouts across dropped frames: a free rollout needs no observation once started, so a recording
that lost two frames (every variable NaN there, as ``tensegrid convert`` writes a missing timestamp)
is predicted to its end and compared only where it was recorded."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from physics import FlopController, ParameterSpace, TrajectoryObjective, simulate
from physics.predictor import held_commands
from physics.replay import replay

DROPPED = [30, 61]          # the commands do not change across them: the held command is the one sent


@pytest.fixture(scope="module")
def flop() -> xr.Dataset:
    """1 s of the nominal robot resting, then flopping (noise-free, every variable recorded)."""
    return simulate(controller=FlopController(heading=0.5), duration=1.0)


def _dropped(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with the frames DROPPED lost: every time-varying variable NaN there."""
    out = ds.copy(deep=True)
    for name, var in out.data_vars.items():
        if "time" in var.dims:
            out[name] = var.where(~out["time"].isin(ds["time"].values[DROPPED]))
    return out


def test_a_free_rollout_runs_on_through_dropped_frames(flop: xr.Dataset) -> None:
    theta = ParameterSpace.t6().nominal
    gappy = _dropped(flop)
    assert np.isnan(gappy["controls"].values[DROPPED]).all()
    with TrajectoryObjective([flop], horizon="rollout", n_workers=0) as whole:
        expected = whole.predictions(theta)[0].values
    with TrajectoryObjective([gappy], horizon="rollout", n_workers=0) as objective:
        predicted = objective.predictions(theta)[0].values
        errors = objective.per_sample(theta)[0]
    assert np.isfinite(predicted[1:]).all()                      # to the end, through both gaps
    np.testing.assert_allclose(predicted[1:], expected[1:], rtol=0, atol=1e-9)
    compared = np.flatnonzero(np.isfinite(errors))
    assert set(range(1, len(errors))) - set(compared) == set(DROPPED)      # compared only where recorded


def test_a_replay_runs_on_through_missing_timestamps(flop: xr.Dataset) -> None:
    """Two samples missing from the clock (a CSV that skipped them) become NaN rows; the replay runs
    the whole recording and its distance is unknown only there."""
    kept = np.setdiff1d(np.arange(flop.sizes["time"]), DROPPED)
    run = replay(flop.isel(time=kept), ParameterSpace.t6().nominal)
    assert run.rollout.sizes["time"] == flop.sizes["time"] and np.isfinite(run.rollout["nodes"].values).all()
    assert list(np.flatnonzero(np.isnan(run.distance()))) == DROPPED
    assert run.errors()[1.0] < 1e-4


def test_held_commands_keep_the_last_command_sent() -> None:
    controls = np.array([[np.nan, 1.0], [2.0, np.nan], [np.nan, np.nan], [3.0, 4.0]])
    np.testing.assert_array_equal(held_commands(controls)[1:], [[2.0, 1.0], [2.0, 1.0], [3.0, 4.0]])
    assert np.isnan(held_commands(controls)[0, 0])               # nothing sent before the first
