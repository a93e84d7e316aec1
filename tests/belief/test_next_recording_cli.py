"""What to record next, end to end: the candidate flops are simulated as the data were recorded,
``tensegrid identify`` prints and writes the suggestion, and ``tensegrid probe --next`` runs it."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from physics import FlopController, ParameterSpace, save_trajectory, simulate
from physics.candidate_recordings import FlopMotion, candidate_objective, flop_motions
from physics.cli import main
from physics.errors import ControllerError
from physics.trajectory_objective import TrajectoryObjective

THETA_STAR = {"damping": 185.0, "pretension": 158.0, "stiffnessActive": 830.0}


@pytest.fixture(scope="module")
def flop(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2 s flop at θ* with 1 mm noise (no velocities, as motion capture records)."""
    path = tmp_path_factory.mktemp("next") / "flop.nc"
    save_trajectory(simulate(THETA_STAR, controller=FlopController(heading=0.5), duration=2.0, noise=0.001, seed=3),
                    path)
    return path


def test_candidates_are_the_resting_face_flops_recorded_like_the_data(flop: Path) -> None:
    """Three edges x the changes, one segment each, simulated at θ and recorded without velocities as
    the data are; the model predicts them better at θ than at another θ (what is left at θ is the
    velocities' estimate from positions), and a motion with a bad timing is refused."""
    from physics.trajectory import load_trajectory

    theta = ParameterSpace.t6().as_array(THETA_STAR)
    with TrajectoryObjective([load_trajectory(flop)], n_workers=0) as data:
        motions = flop_motions(data, theta, changes=(0.3,), n_cables=(4,), duration=2.0)
        assert len(motions) == 3 and len({round(m.heading, 6) for m in motions}) == 3
        with candidate_objective(data, theta, motions[:2]) as candidates:
            assert len(candidates.segments) == 2
            assert all("velocities" not in ds for ds in candidates.trajectories)
            other = ParameterSpace.t6().as_array({**THETA_STAR, "stiffnessActive": 760.0, "damping": 210.0})
            rms = [[float(np.sqrt(np.nanmean(r ** 2))) for r in candidates.residuals(t)] for t in (theta, other)]
            made_at = [np.asarray(ds["theta"].values) for ds in candidates.trajectories]
    assert all(np.allclose(t, theta) for t in made_at)
    assert all(at_truth < off for at_truth, off in zip(*rms, strict=True)), rms
    with pytest.raises(ControllerError):
        FlopMotion(heading=0.0, start=1.5, stop=1.2)


def test_identify_suggests_a_recording_and_probe_runs_it(flop: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "id"
    # random search of 3 evaluations, the T6's D + 4 = 19 of the budget kept for the assessment
    assert main(["identify", str(flop), "--preset", "random", "--budget", "22", "--no-progress", "--workers", "2",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr()
    assert "What to record next (9 candidate flops" in printed.out
    assert "scoring 9 candidate flops (about" in printed.err
    record = json.loads((out / "next_recording.json").read_text())
    assert len(record["candidates"]) == 9 and record["motion"] == record["candidates"][0]["motion"]
    gains = [c["gain"] for c in record["candidates"]]
    assert gains == sorted(gains, reverse=True) and np.all(np.isfinite(gains))
    assert "What to record next" in (out / "summary.txt").read_text()
    probed = tmp_path / "probe"
    assert main(["probe", str(out / "result.nc"), "--next", str(out / "next_recording.json"), "--truth", str(flop),
                 "--steps", "1", "--cells", "4", "--out", str(probed)]) == 0
    step = json.loads((probed / "probe.json").read_text())["steps"][0]
    assert step["action"] == record["motion"]


def test_probe_refuses_a_file_that_is_not_a_suggestion(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "next.json"
    bad.write_text(json.dumps({"heading": 1.0}))
    assert main(["probe", "nominal.nc", "--next", str(bad), "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert "not a next_recording.json" in err and not (tmp_path / "p").exists()
