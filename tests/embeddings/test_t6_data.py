"""The T6 transition set (simulated, cached), the dynamics network on it, and `tensegrid train-embedding`."""
from __future__ import annotations

import argparse

import numpy as np
import pytest

from embeddings import DynamicsNetwork, EmbeddingError, T6DataConfig, TrainingConfig, Transitions, t6_transitions
from embeddings.cli import register_train_embedding
from physics.parameters import ParameterSpace

SPACE = ParameterSpace.t6()
SMALL = T6DataConfig(n_trajectories=6, duration=0.8, stride=4, horizon=10, seed=0)


@pytest.fixture(scope="module")
def small_set(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    return t6_transitions(SMALL, cache_dir=cache, workers=0, progress=False), cache


def test_rows_shapes_and_cache(small_set) -> None:
    data, cache = small_set
    per_trajectory = len(range(0, 81 - SMALL.horizon, SMALL.stride))
    assert len(data) == 6 * per_trajectory and data.context.shape[1] == 96 and data.target.shape[1] == 3
    assert sorted(set(data.group)) == list(range(6)) and data.attrs["diverged"] == 0
    assert np.all(data.theta >= SPACE.lower) and np.all(data.theta <= SPACE.upper)
    files = list(cache.glob("t6-transitions-*.nc"))
    assert len(files) == 1
    again = t6_transitions(SMALL, cache_dir=cache, workers=0, progress=False)       # read back, not simulated
    assert np.array_equal(again.context, data.context) and np.array_equal(again.theta, data.theta)
    other = Transitions.load(files[0])
    assert other.target_names == ("dcom_x", "dcom_y", "dcom_z")


def test_dynamics_network_beats_the_mean_on_held_out_trajectories(small_set) -> None:
    data, _ = small_set
    train, test = data.split(0.34, seed=0)
    assert not set(train.group) & set(test.group)
    net = DynamicsNetwork(SPACE).fit(train, training=TrainingConfig(epochs=40, batch_size=64, seed=0))
    score = net.score(test)
    print(f"T6 dynamics network, {len(set(test.group))} held-out trajectories: MSE {score.mse:.3g} m² vs "
          f"{score.baseline_mse:.3g} for the mean (ratio {score.ratio:.3f})")
    assert score.ratio < 0.5


def test_counterfactual_target_is_what_theta_changes(tmp_path) -> None:
    """At the nominal θ' the counterfactual target is exactly zero; elsewhere it is not; θ' is not the
    θ that made the state; the set caches under its own key."""
    from embeddings.t6_data import _features
    from physics import FlopController, simulate

    config = T6DataConfig(n_trajectories=2, duration=0.5, stride=10, horizon=10, counterfactual=True)
    for theta, zero in ((SPACE.nominal, True), (SPACE.sample(1, seed=3)[0], False)):
        ds = simulate(theta, controller=FlopController(heading=0.7), duration=0.5, space=SPACE)
        context, target = _features(ds, config, theta, SPACE)
        assert target.shape == (len(context), 3) and np.all(np.isfinite(target))
        assert (np.abs(target).max() == 0.0) == zero
    data = t6_transitions(config, cache_dir=tmp_path, workers=0, progress=False)
    plain = t6_transitions(T6DataConfig(n_trajectories=2, duration=0.5, stride=10, horizon=10), cache_dir=tmp_path,
                           workers=0, progress=False)
    assert data.target_names == ("dcom_x_vs_nominal", "dcom_y_vs_nominal", "dcom_z_vs_nominal")
    assert np.array_equal(data.context, plain.context) and len(list(tmp_path.glob("*.nc"))) == 2
    assert not np.array_equal(data.theta, plain.theta)          # θ' is drawn apart from the state's θ
    assert np.abs(data.target).mean() < np.abs(plain.target).mean()


def test_bad_settings_are_refused() -> None:
    with pytest.raises(EmbeddingError, match="summary must be one of"):
        T6DataConfig(summary="energy")
    with pytest.raises(EmbeddingError, match="too short for a horizon"):
        T6DataConfig(duration=0.05, horizon=10)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tensegrid")
    register_train_embedding(parser.add_subparsers(dest="command", required=True))
    return parser


def test_train_embedding_then_identify_with_it(tmp_path, capsys) -> None:
    """The command line: train a push-toy autoencoder, then search its 1-D latent."""
    from belief.cli import register_identify

    out = tmp_path / "ae.json"
    args = _parser().parse_args(["train-embedding", "ae-dyn", "--toy", "push", "--samples", "3000", "--epochs", "5",
                                 "--out", str(out), "--no-progress"])
    assert args.func(args) == 0
    printed = capsys.readouterr().out
    assert "held-out MSE" in printed and out.exists() and (tmp_path / "ae.dynamics.json").exists()
    parser = argparse.ArgumentParser(prog="tensegrid")
    register_identify(parser.add_subparsers(dest="command", required=True))
    # 5 evaluations in the latent grid; the push toy's D + 4 = 6 of the budget kept for the assessment
    run = parser.parse_args(["identify", "--toy", "push", "--preset", "latent", "--decoder", "ae-dyn", "--decoder-file", str(out),
                             "--budget", "11", "--out", str(tmp_path / "id"), "--no-progress"])
    assert run.func(run) == 0
    wrong = parser.parse_args(["identify", "--toy", "push", "--preset", "latent", "--decoder", "vae", "--decoder-file", str(out),
                               "--budget", "11", "--out", str(tmp_path / "id2"), "--no-progress"])
    assert wrong.func(wrong) == 2
    assert "holds a ae-dyn decoder" in capsys.readouterr().err
    toy = _parser().parse_args(["train-embedding", "ae-dyn", "--toy", "push", "--counterfactual", "--out",
                                str(tmp_path / "cf.json"), "--no-progress"])
    assert toy.func(toy) == 2 and "--counterfactual applies to the T6" in capsys.readouterr().err
