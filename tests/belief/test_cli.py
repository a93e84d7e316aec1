"""``tensegrid identify --toy push``: runs through argparse, writes result, tables and figures; usage errors."""
from __future__ import annotations

import argparse

import pytest

from belief import IdentificationResult
from belief.cli import register_identify


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tensegrid")
    register_identify(parser.add_subparsers(dest="command", required=True))
    return parser


# every preset keeps D + 4 = 6 evaluations of the push toy's budget (D = 2) for after its search
@pytest.mark.parametrize("preset,extra,budget,n", [
    ("bo", [], 16, 16 - 6), ("latent", ["--decoder", "rembo"], 16, 16 - 6), ("random", [], 16, 16 - 6),
    ("bo-gn", [], 10, 10 - 6)])
def test_identify_push_toy_writes_everything(tmp_path, preset: str, extra: list, budget: int, n: int, capsys) -> None:
    out = tmp_path / preset
    args = _parser().parse_args(["identify", "--toy", "push", "--preset", preset, *extra, "--budget", str(budget),
                                 "--out", str(out), "--no-progress", "--points-per-dim", "15"])
    assert args.func(args) == 0
    for name in ("result.nc", "summary.txt", "marginals.csv", "history.csv", "error_vs_evaluations.png",
                 "posterior_marginals.png", "journal.sqlite"):
        assert (out / name).stat().st_size > 0, name
    res = IdentificationResult.load(out / "result.nc")
    assert res.n_evaluations == n and abs(float(res.posterior.sum()) - 1) < 1e-9
    assert res.config["evaluations"]["search"] == n and res.config["evaluations"]["total"] <= budget
    assert res.config["preset"] == preset
    assert (out / "history.csv").read_text().count("\n") == n + 1
    printed = capsys.readouterr().out
    assert "best error" in printed and f"preset {preset}:" in printed
    if preset == "bo":
        assert (out / "posterior_2d.png").exists()
    # re-running resumes from the journal: nothing new to evaluate, same history
    assert args.func(args) == 0
    again = IdentificationResult.load(out / "result.nc")
    assert (again.history["cell"].values == res.history["cell"].values).all()


def test_the_default_preset_is_the_librarys_best(tmp_path, capsys) -> None:
    from belief.presets import DEFAULT_PRESET

    args = _parser().parse_args(["identify", "--toy", "push", "--budget", "12", "--out", str(tmp_path / "d"),
                                 "--no-progress"])
    assert args.preset == DEFAULT_PRESET
    assert args.func(args) == 0
    captured = capsys.readouterr()
    assert "no latent decoder for this parameter space" in captured.err     # the push toy has none shipped
    assert IdentificationResult.load(tmp_path / "d" / "result.nc").config["local_step"]["evaluations"] == 6


def test_usage_errors(tmp_path, capsys) -> None:
    p = _parser()
    args = p.parse_args(["identify", "--out", str(tmp_path)])
    assert args.func(args) == 2
    assert "exactly one" in capsys.readouterr().err
    args = p.parse_args(["identify", "--toy", "push", "--budget", "6", "--out", str(tmp_path), "--no-progress"])
    assert args.func(args) == 2
    assert "budget=6 is too small for preset 'handoff-gn'" in capsys.readouterr().err
    args = p.parse_args(["identify", "--toy", "push", "--preset", "bo", "--budget", "0", "--out", str(tmp_path)])
    assert args.func(args) == 2
    assert "budget must be >= 1" in capsys.readouterr().err
    args = p.parse_args(["identify", "--toy", "push", "--decoder", "vae", "--out", str(tmp_path), "--no-progress"])
    assert args.func(args) == 2
    assert "needs --decoder-file" in capsys.readouterr().err
    args = p.parse_args(["identify", "--toy", "push", "--decoder", "active", "--out", str(tmp_path), "--no-progress"])
    assert args.func(args) == 2
    assert "ActiveSubspace.fit(...).save(FILE)" in capsys.readouterr().err
    args = p.parse_args(["identify", "--toy", "push", "--decoder-file", "x.json", "--out", str(tmp_path)])
    assert args.func(args) == 2
    assert "needs --decoder vae, ae-dyn or active" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        p.parse_args(["identify", "--toy", "push", "--decoder", "pca", "--out", str(tmp_path)])
    args = p.parse_args(["identify", "--toy", "push", "--preset", "bo", "--latent", "4", "--out", str(tmp_path)])
    assert args.func(args) == 2
    assert "has none" in capsys.readouterr().err
    args = p.parse_args(["identify", "--toy", "push", "--preset", "bo", "--decoder", "rembo", "--out", str(tmp_path)])
    assert args.func(args) == 2
    assert "full space only" in capsys.readouterr().err
    args = p.parse_args(["identify", "--toy", "push", "--preset", "handoff", "--decoder", "rembo", "--latent", "10",
                         "--budget", "10", "--out", str(tmp_path)])
    assert args.func(args) == 2
    assert "give at least 17" in capsys.readouterr().err         # 10 latent + 1 + the D + 4 = 6 kept after


def test_handoff_continues_in_the_full_space(tmp_path) -> None:
    out = tmp_path / "handoff"
    args = _parser().parse_args(["identify", "--toy", "push", "--preset", "handoff", "--decoder", "rembo", "--dim", "1",
                                 "--latent", "5", "--budget", "17", "--candidates", "256", "--out", str(out), "--no-progress"])
    assert args.func(args) == 0
    res = IdentificationResult.load(out / "result.nc")
    assert res.n_evaluations == 17 - 6 and res.config["decoder"]["kind"] == "identity"   # 6 = D + 4 kept after
    assert res.config["grid"]["n"] == 256 and len(res.config["grid"]["include"]) == 5
    assert (out / "journal-latent.sqlite").exists() and (out / "posterior_marginals.png").stat().st_size > 0


@pytest.mark.slow
def test_identify_t6_trajectory_file(tmp_path) -> None:
    """The DATA.nc path: a short simulated SUPERball trajectory, REMBO, a tiny budget."""
    from physics import FlopController, ParameterSpace, save_trajectory, simulate

    space = ParameterSpace.t6()
    data = simulate(space.sample(1, seed=3)[0], controller=FlopController(heading=0.0), duration=0.5)
    path = save_trajectory(data, tmp_path / "obs.nc")
    out = tmp_path / "out"
    args = _parser().parse_args(["identify", str(path), "--preset", "latent", "--decoder", "rembo", "--dim", "3", "--points-per-dim", "5",
                                 "--budget", "25", "--out", str(out), "--no-progress", "--no-next"])
    assert args.func(args) == 0
    res = IdentificationResult.load(out / "result.nc")
    assert res.n_evaluations == 25 - 19 and res.marginals.sizes["parameter"] == 15     # 19 = D + 4 kept after
    assert res.config["objective"]["kind"] == "T6 TrajectoryObjective"
    assert (out / "posterior_marginals.png").exists() and (out / "observed_vs_predicted.png").exists()


@pytest.fixture(scope="module")
def two_files(tmp_path_factory):
    """Two short SUPERball trajectories (same θ, flops toward +x and +y), saved as netCDF."""
    from physics import FlopController, ParameterSpace, save_trajectory, simulate

    theta = ParameterSpace.t6().sample(1, seed=3)[0]
    folder = tmp_path_factory.mktemp("data")
    return [str(save_trajectory(simulate(theta, controller=FlopController(heading=h), duration=0.4), folder / f"{k}.nc"))
            for k, h in enumerate((0.0, 1.5708))]


@pytest.mark.slow
def test_identify_several_trajectory_files_make_one_objective(tmp_path, two_files, capsys) -> None:
    out = tmp_path / "out"
    args = _parser().parse_args(["identify", *two_files, "--preset", "random", "--budget", "22", "--windows", "2",
                                 "--out", str(out), "--no-progress", "--no-next"])
    assert args.data == two_files and args.windows == 2
    assert args.func(args) == 0
    res = IdentificationResult.load(out / "result.nc")
    assert res.n_evaluations == 22 - 19                     # the T6's D + 4 = 19 kept for the assessment
    assert res.config["objective"]["segments"] == ["t0/w0", "t0/w1", "t1/w0", "t1/w1"]
    assert (out / "observed_vs_predicted.png").stat().st_size > 0


def test_trajectory_usage_errors(tmp_path, two_files, capsys) -> None:
    p = _parser()
    args = p.parse_args(["identify", *two_files, "--toy", "push", "--out", str(tmp_path)])
    assert args.func(args) == 2
    assert "exactly one" in capsys.readouterr().err
    args = p.parse_args(["identify", *two_files, "--windows", "0", "--out", str(tmp_path), "--no-progress"])
    assert args.func(args) == 2
    assert "windows must be an integer >= 1" in capsys.readouterr().err

