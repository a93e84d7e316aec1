"""E(θ): ~0 at the truth on noise-free data, growing away from it; failures in batches; dask."""
from __future__ import annotations

import numpy as np
import pytest

from physics import (
    STATUSES, ModelOptions, ParameterError, PhysicsError, StateEstimator, TrajectoryFormatError, TrajectoryObjective,
)

# motor_friction acts on the motion (test_model) but its one-step signal (+3e-8 at +5 %) is far
# below the floor left by the unobserved axial spin of the rods (E(θ*) ≈ 0.009 on these data):
# it is identifiable only through longer horizons (see the rollout test below and docs/physics.md).
ONE_STEP_BLIND = {"motor_friction"}


def test_one_step_error_is_near_zero_at_the_truth_and_grows_along_each_parameter(space, flop_data):
    E = TrajectoryObjective(flop_data, loss="norm")
    e0 = E(space.nominal)
    n_compared = int(np.isfinite(E.per_sample(space.nominal)[0]).sum())
    assert e0 / n_compared < 1e-4           # < 0.1 mm per sample over 36 coordinates
    for name in space.names:
        if name in ONE_STEP_BLIND:
            continue
        values = [E(space.replace(**{name: space[name].nominal * (1 + f)})) for f in (-0.1, -0.05, 0.05, 0.1)]
        assert values[0] > values[1] > e0 and values[3] > values[2] > e0, f"{name}: {values} vs {e0}"


@pytest.mark.slow
def test_rollout_error_grows_along_every_parameter(space, flop_data):
    E = TrajectoryObjective(flop_data, horizon="rollout", loss="norm")
    e0 = E(space.nominal)
    assert e0 < 0.01
    for name in space.names:
        for f in (-0.05, 0.05):
            assert E(space.replace(**{name: space[name].nominal * (1 + f)})) > e0 + 1e-3, name


def test_estimated_velocities_leave_a_small_floor(space, flop_data):
    """Without recorded velocities the backward-difference estimate costs accuracy, but the truth
    still wins against 5 % errors in the strongest parameters."""
    E = TrajectoryObjective(flop_data.drop_vars("velocities"), loss="norm")
    e0 = E(space.nominal)
    for name in ("density", "stiffnessActive", "pretension"):
        assert E(space.replace(**{name: space[name].nominal * 1.05})) > e0


def test_horizons_and_actuator_sources_agree_at_the_truth(space, flop_data):
    for kwargs in (dict(horizon=10), dict(actuators="measured"), dict(actuators="auto")):
        assert TrajectoryObjective(flop_data, loss="norm", **kwargs)(space.nominal) < 0.05


def test_missing_samples_are_skipped(space, flop_data):
    holey = flop_data.copy(deep=True)
    holey["nodes"][100:103] = np.nan
    holey["controls"][200:202] = np.nan
    E = TrajectoryObjective(holey.drop_vars("velocities"))
    per = E.per_sample(space.nominal)[0]
    assert np.isnan(per[100:104]).all()           # the holes, and the prediction from the missing state x_102
    assert np.isfinite(per[104])                  # from x_103, its fit leaves the missing samples out
    assert np.isfinite(per[110:200]).all()
    assert np.isnan(per[201:203]).all()           # no prediction without the command
    assert np.isfinite(E(space.nominal))
    backward = TrajectoryObjective(holey.drop_vars("velocities"), states=StateEstimator(method="backward"))
    per = backward.per_sample(space.nominal)[0]
    assert np.isnan(per[100:105]).all()           # x_103's backward difference needs x_102
    assert np.isfinite(per[105])                  # from x_104, velocity by first-order difference


def test_squared_loss_is_the_sum_of_squared_residuals(space, flop_data):
    theta = space.replace(damping=190.0)
    per = TrajectoryObjective(flop_data).per_sample(theta)[0]
    squared = TrajectoryObjective(flop_data, loss="squared")
    assert np.isclose(squared(theta), np.nansum(per**2))
    assert squared.n_observations == 36 * int(np.isfinite(per).sum())
    with pytest.raises(ParameterError, match="loss must be"):
        TrajectoryObjective(flop_data, loss="l1")


def test_many_trajectories_add_up(space, flop_data):
    one = TrajectoryObjective(flop_data)(space.nominal)
    two = TrajectoryObjective([flop_data, flop_data])(space.nominal)
    assert np.isclose(two, 2 * one)


def test_divergence_raises_alone_and_is_recorded_in_a_batch(space, flop_data):
    E = TrajectoryObjective(flop_data.isel(time=slice(0, 50)))
    theta = space.replace(stiffnessActive=1e7)  # explicit integration is unstable: ω dt = 2.6 > 2
    with pytest.raises(PhysicsError, match="diverged"):
        E(theta)
    seen = []
    result = E.evaluate_batch(np.stack([space.nominal, theta]), parallel=False,
                              on_result=lambda k, e, st, sec, msg, parts: seen.append((k, st, parts.shape)))
    assert result.status == ("ok", "diverged") and set(result.status) <= set(STATUSES)
    assert seen == [(0, "ok", (3,)), (1, "diverged", (3,))]
    assert np.isfinite(result.errors[0]) and np.isnan(result.errors[1])
    assert result.parts.shape == (2, 3) and np.isnan(result.parts[1]).all()
    assert result.errors[0] == result.parts[0].sum() == E(space.nominal)
    assert "diverged" in result.messages[1] and result.messages[0] == ""
    assert (result.seconds > 0).all()


def test_calling_on_a_batch_points_to_evaluate_batch(space, flop_data):
    E = TrajectoryObjective(flop_data.isel(time=slice(0, 50)))
    with pytest.raises(ParameterError, match="evaluate_batch"):
        E(np.stack([space.nominal, space.nominal]))


def test_residuals_batch_matches_residuals_and_marks_divergence(space, flop_data):
    E = TrajectoryObjective(flop_data.isel(time=slice(0, 50)), horizon=5, loss="squared")
    diverging = space.replace(stiffnessActive=1e7)
    rows = E.residuals_batch(np.stack([space.nominal, diverging, space.replace(damping=150.0)]), parallel=False)
    assert rows[1] is None
    for got, theta in zip(rows[::2], (space.nominal, space.replace(damping=150.0))):
        want = E.residuals(theta)
        assert len(got) == len(E.segments) and all(np.array_equal(a, b, equal_nan=True) for a, b in zip(got, want))
        assert sum(np.nansum(r ** 2) for r in got) == pytest.approx(E(theta))


@pytest.mark.slow
def test_batch_on_a_local_dask_cluster_matches_serial(space, flop_data):
    thetas = space.sample(4, seed=3)
    streamed = {}
    with TrajectoryObjective(flop_data.isel(time=slice(0, 120)), n_workers=2) as E:
        parallel = E.evaluate_batch(thetas, on_result=lambda k, e, st, sec, msg, parts: streamed.setdefault(k, (e, st)))
        serial = E.evaluate_batch(thetas, parallel=False)
        np.testing.assert_array_equal(parallel.errors, serial.errors)
        np.testing.assert_array_equal(parallel.parts, serial.parts)
        np.testing.assert_array_equal([E(theta) for theta in thetas], serial.errors)
        assert [e for e, _ in parallel] == serial.errors.tolist()
    assert parallel.status == ("ok",) * 4
    # every row was handed over once as it finished, with the same values
    assert sorted(streamed) == [0, 1, 2, 3]
    assert [streamed[k] for k in range(4)] == list(parallel)


@pytest.mark.slow
def test_batch_on_an_existing_scheduler(space, flop_data):
    from distributed import LocalCluster
    thetas = space.sample(2, seed=4)
    data = flop_data.isel(time=slice(0, 60))
    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=None) as cluster:
        with TrajectoryObjective(data, address=cluster.scheduler_address) as E:
            remote = E.evaluate_batch(thetas)
            assert E._pool.cluster is None     # it used the given scheduler, started none
    np.testing.assert_array_equal(remote.errors, TrajectoryObjective(data).evaluate_batch(thetas, parallel=False).errors)


def test_validation(space, flop_data):
    with pytest.raises(ParameterError, match="horizon"):
        TrajectoryObjective(flop_data, horizon=0)
    with pytest.raises(ParameterError, match="actuators"):
        TrajectoryObjective(flop_data, actuators="guess")
    with pytest.raises(TrajectoryFormatError, match="at least one trajectory"):
        TrajectoryObjective([])
    with pytest.raises(TrajectoryFormatError, match="whole number of physics steps"):
        TrajectoryObjective(flop_data, options=ModelOptions(dt=0.003))
    with pytest.raises(TrajectoryFormatError, match="needs a 'rest_length'"):
        TrajectoryObjective(flop_data.drop_vars("rest_length"), actuators="measured")(space.nominal)
    with pytest.raises(ParameterError, match="shape"):
        TrajectoryObjective(flop_data)(np.ones(3))
    for bad in (0, -1, 1.5, True, "3"):
        with pytest.raises(ParameterError, match=r"windows must be an integer >= 1.*windows=1"):
            TrajectoryObjective(flop_data, windows=bad)
    short = flop_data.isel(time=slice(0, 20)).copy(deep=True)
    short["nodes"][:-1] = np.nan
    with pytest.raises(TrajectoryFormatError, match="no sample can be predicted and compared"):
        TrajectoryObjective(short)


# ---------------------------------------------------------------------------- segments and parts
@pytest.fixture(scope="module")
def short_data(flop_data):
    return flop_data.isel(time=slice(0, 61))


def test_segments_split_the_compared_samples_into_nearly_equal_contiguous_groups(space, short_data):
    E = TrajectoryObjective([short_data, short_data.isel(time=slice(0, 31))], windows=4)
    assert E.segments == ("t0/w0", "t0/w1", "t0/w2", "t0/w3", "t1/w0", "t1/w1", "t1/w2", "t1/w3")
    assert E.fingerprint()["segments"] == list(E.segments) and E.fingerprint()["windows"] == 4
    assert E.fingerprint() != TrajectoryObjective([short_data, short_data.isel(time=slice(0, 31))]).fingerprint()
    res = E.residuals(space.nominal)
    assert len(res) == 8 and all(r.shape[1] == 36 for r in res)
    sizes = [int(np.isfinite(r).all(axis=1).sum()) for r in res]
    assert sizes == [15, 15, 15, 15, 8, 8, 7, 7]        # 60 and 30 compared samples
    assert sum(r.shape[0] for r in res[:4]) == 60       # contiguous, covering samples 1..60 once
    # fewer compared samples than windows: fewer segments
    tiny = TrajectoryObjective(short_data.isel(time=slice(0, 4)), windows=5)
    assert tiny.segments == ("t0/w0", "t0/w1", "t0/w2")
    assert len(tiny.evaluate_parts(space.nominal)) == 3


@pytest.mark.parametrize("loss, power", [("norm", 1), ("squared", 2)])
def test_parts_sum_to_the_error_and_residuals_reproduce_it(space, short_data, loss, power):
    theta = space.replace(damping=190.0)
    E = TrajectoryObjective(short_data, loss=loss, horizon=7)
    parts = E.evaluate_parts(theta)
    per = E.per_sample(theta)[0]
    assert parts.shape == (3,) and (parts > 0).all()
    assert np.isclose(parts.sum(), np.nansum(per**power), rtol=1e-12)
    assert E(theta) == parts.sum()
    res = E.residuals(theta)
    if loss == "squared":
        assert np.isclose(sum(np.nansum(r**2) for r in res), E(theta), rtol=1e-12)
    norms = np.concatenate([np.linalg.norm(r, axis=1) for r in res])
    assert np.isclose(np.nansum(norms**power), E(theta), rtol=1e-12)
    # node-major layout: residual row of sample i is (x_obs - x_pred)[i].ravel()
    pred = E.predictions(theta)[0].values
    np.testing.assert_allclose(res[0][0], (short_data["nodes"].values[1] - pred[1]).ravel())


def test_residuals_have_nan_rows_where_nothing_was_compared(space, short_data):
    holey = short_data.copy(deep=True)
    holey["nodes"][20:22] = np.nan
    E = TrajectoryObjective(holey, loss="squared", windows=2)
    res = E.residuals(space.nominal)
    rows = np.concatenate(res)
    assert rows.shape == (60, 36)                        # samples 1..60 in time order
    nan_rows = ~np.isfinite(rows).all(axis=1)
    assert (np.isnan(rows[nan_rows])).all()              # a row is all NaN or all finite
    assert nan_rows[19:21].all() and not nan_rows[:19].any()
    assert np.isclose(sum(np.nansum(r**2) for r in res), E(space.nominal))


def test_one_prediction_pass_per_evaluation(space, short_data, monkeypatch):
    import physics.trajectory_objective as module
    calls = []
    original = module.predict

    def counting(*args, **kwargs):
        calls.append(args[2])
        return original(*args, **kwargs)

    monkeypatch.setattr(module, "predict", counting)
    E = TrajectoryObjective(short_data, horizon=10, n_workers=0)
    result = E.evaluate_batch(space.nominal[None], on_result=lambda *row: None)
    assert result.status == ("ok",) and len(calls) == 6   # 6 windows of 10 samples, each run once
