"""E(θ): ~0 at the truth on noise-free data, growing away from it; failures in batches; dask."""
from __future__ import annotations

import numpy as np
import pytest

from physics import (
    FlopController, ModelOptions, ParameterError, ParameterSpace, PhysicsError, TrajectoryError,
    TrajectoryFormatError, simulate,
)

# motor_friction acts on the motion (test_model) but its one-step signal (+3e-8 at +5 %) is far
# below the floor left by the unobserved axial spin of the rods (E(θ*) ≈ 0.009 on these data):
# it is identifiable only through longer horizons (see the rollout test below and docs/physics.md).
ONE_STEP_BLIND = {"motor_friction"}


def test_one_step_error_is_near_zero_at_the_truth_and_grows_along_each_parameter(space, flop_data):
    E = TrajectoryError(flop_data)
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
    E = TrajectoryError(flop_data, horizon="rollout")
    e0 = E(space.nominal)
    assert e0 < 0.01
    for name in space.names:
        for f in (-0.05, 0.05):
            assert E(space.replace(**{name: space[name].nominal * (1 + f)})) > e0 + 1e-3, name


def test_estimated_velocities_leave_a_small_floor(space, flop_data):
    """Without recorded velocities the backward-difference estimate costs accuracy, but the truth
    still wins against 5 % errors in the strongest parameters."""
    E = TrajectoryError(flop_data.drop_vars("velocities"))
    e0 = E(space.nominal)
    for name in ("density", "stiffnessActive", "pretension"):
        assert E(space.replace(**{name: space[name].nominal * 1.05})) > e0


def test_horizons_and_actuator_sources_agree_at_the_truth(space, flop_data):
    for kwargs in (dict(horizon=10), dict(actuators="measured"), dict(actuators="auto")):
        assert TrajectoryError(flop_data, **kwargs)(space.nominal) < 0.05


def test_missing_samples_are_skipped(space, flop_data):
    holey = flop_data.copy(deep=True)
    holey["nodes"][100:103] = np.nan
    holey["controls"][200:202] = np.nan
    E = TrajectoryError(holey.drop_vars("velocities"))
    per = E.per_sample(space.nominal)[0]
    assert np.isnan(per[100:105]).all()           # the holes, and predictions from states that need them
    assert np.isfinite(per[105])                  # from x_104, velocity by first-order difference
    assert np.isfinite(per[110:200]).all()
    assert np.isnan(per[201:203]).all()           # no prediction without the command
    assert np.isfinite(E(space.nominal))


def test_squared_loss_is_the_sum_of_squared_residuals(space, flop_data):
    theta = space.replace(damping=190.0)
    per = TrajectoryError(flop_data).per_sample(theta)[0]
    squared = TrajectoryError(flop_data, loss="squared")
    assert np.isclose(squared(theta), np.nansum(per**2))
    assert squared.n_observations == 36 * int(np.isfinite(per).sum())
    with pytest.raises(ParameterError, match="loss must be"):
        TrajectoryError(flop_data, loss="l1")


def test_many_trajectories_add_up(space, flop_data):
    one = TrajectoryError(flop_data)(space.nominal)
    two = TrajectoryError([flop_data, flop_data])(space.nominal)
    assert np.isclose(two, 2 * one)


def test_divergence_raises_alone_and_is_recorded_in_a_batch(space, flop_data):
    E = TrajectoryError(flop_data.isel(time=slice(0, 50)))
    theta = space.replace(stiffnessActive=1e7)  # explicit integration is unstable: ω dt = 2.6 > 2
    with pytest.raises(PhysicsError, match="diverged"):
        E(theta)
    seen = []
    result = E.evaluate_batch(np.stack([space.nominal, theta]), parallel=False,
                              on_result=lambda k, e, st, sec, msg: seen.append((k, st)))
    assert result.status == ("ok", "diverged")
    assert seen == [(0, "ok"), (1, "diverged")]
    assert np.isfinite(result.errors[0]) and np.isnan(result.errors[1])
    assert "diverged" in result.messages[1]


@pytest.mark.slow
def test_batch_on_a_local_dask_cluster_matches_serial(space, flop_data):
    thetas = space.sample(4, seed=3)
    streamed = {}
    with TrajectoryError(flop_data.isel(time=slice(0, 120)), n_workers=2) as E:
        parallel = E.evaluate_batch(thetas, on_result=lambda k, e, st, sec, msg: streamed.setdefault(k, (e, st)))
        serial = E.evaluate_batch(thetas, parallel=False)
        np.testing.assert_array_equal(parallel.errors, serial.errors)
        np.testing.assert_array_equal(E(thetas), serial.errors)
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
        with TrajectoryError(data, address=cluster.scheduler_address) as E:
            remote = E.evaluate_batch(thetas)
            assert E._cluster is None          # it used the given scheduler, started none
    np.testing.assert_array_equal(remote.errors, TrajectoryError(data).evaluate_batch(thetas, parallel=False).errors)


def test_validation(space, flop_data):
    with pytest.raises(ParameterError, match="horizon"):
        TrajectoryError(flop_data, horizon=0)
    with pytest.raises(ParameterError, match="actuators"):
        TrajectoryError(flop_data, actuators="guess")
    with pytest.raises(TrajectoryFormatError, match="at least one trajectory"):
        TrajectoryError([])
    with pytest.raises(TrajectoryFormatError, match="whole number of physics steps"):
        TrajectoryError(flop_data, options=ModelOptions(dt=0.003))
    with pytest.raises(TrajectoryFormatError, match="needs a 'rest_length'"):
        TrajectoryError(flop_data.drop_vars("rest_length"), actuators="measured")(space.nominal)
    with pytest.raises(ParameterError, match="shape"):
        TrajectoryError(flop_data)(np.ones(3))
