"""The mismatch stage's journal (criticism.stage_journal): a report survives the round trip, a
second run of the same problem reads it instead of running the stage, and a stage of another
problem is refused as a journal of another problem is."""
from __future__ import annotations

import json

import numpy as np
import pytest

from belief.bounds import AtBound
from belief.journal import JournalMismatchError
from criticism import stage_journal
from criticism.held_out import HeldScores
from criticism.mismatch import MismatchConfig, MismatchReport, Trial
from criticism.stage_journal import STAGE_JOURNAL, journalled_stage
from physics import FlopController, TrajectoryObjective, simulate
from physics.effects import CableAnchors, TensionLimitedActuation


def _report() -> MismatchReport:
    effects = (TensionLimitedActuation(), CableAnchors())
    trial = Trial(1, "cable_anchors", {"anchor_offset": 0.061}, 2.5, 0.31, True, (1.0, 2.0, 0.061))
    scores = HeldScores({"t2": 0.4}, {"t2": 1.5}, {"t2": 0.05})
    where = {"phases": {"rest": {"share": 0.2}, "motion": {"share": 0.8}}, "top_nodes": [3, 7],
             "axis_share": {"x": 0.3, "y": 0.3, "z": 0.4}, "frequency_share": {"0-1 Hz": 0.9, "1-5 Hz": 0.1}}
    bound = AtBound("damping", "N·s/m", "upper", 220.0, 219.9, 200.0, "re-tuning")
    return MismatchReport(effects, ("a", "b", "anchor_offset"), np.array([1.0, 2.0, 0.061]), np.array([1.1, 2.1]),
                          [trial], scores, HeldScores({"t2": 0.2}, {"t2": 0.9}, {"t2": 0.03}), where, where,
                          (bound,), in_sample=False)


def test_a_report_survives_its_json_record() -> None:
    report = _report()
    back = MismatchReport.from_dict(json.loads(json.dumps(report.as_dict())))
    assert back.as_dict() == report.as_dict()
    assert [e.name for e in back.effects] == ["tension_limited_actuator", "cable_anchors"]
    assert back.text() == report.text()


@pytest.fixture(scope="module")
def objective() -> TrajectoryObjective:
    data = [simulate(None, controller=FlopController(heading=h), duration=0.3, seed=k) for k, h in enumerate((0, 2))]
    return TrajectoryObjective(data, loss="squared", n_workers=0)


def test_a_second_run_reads_the_stage_and_another_problem_is_refused(objective, tmp_path, monkeypatch) -> None:
    calls = []

    def stage(*args, **kwargs) -> MismatchReport:
        calls.append(args)
        return _report()

    monkeypatch.setattr(stage_journal, "absorb_mismatch", stage)
    fit = np.ones(len(objective.segments), bool)
    config = MismatchConfig()
    tmp_path = tmp_path / "robot-0"                                   # a folder not made yet is made
    first = journalled_stage(objective, fit, [1], config=config, journal_dir=tmp_path, progress=False)
    assert len(calls) == 1 and (tmp_path / STAGE_JOURNAL).exists()
    assert not list(tmp_path.glob("*.partial"))                       # written whole
    again = journalled_stage(objective, fit, [1], config=config, journal_dir=tmp_path, progress=False)
    assert len(calls) == 1                                             # read back, not run again
    assert again.as_dict() == first.as_dict()
    with pytest.raises(JournalMismatchError, match="another problem"):
        journalled_stage(objective, fit, [0], config=config, journal_dir=tmp_path, progress=False)
    with pytest.raises(JournalMismatchError, match="another problem"):
        journalled_stage(objective, fit, [1], config=MismatchConfig(rounds=1), journal_dir=tmp_path, progress=False)
    (tmp_path / STAGE_JOURNAL).write_text("{not json")
    with pytest.raises(JournalMismatchError, match="cannot be read"):
        journalled_stage(objective, fit, [1], config=config, journal_dir=tmp_path, progress=False)
    journalled_stage(objective, fit, [1], config=config, journal_dir=None, progress=False)
    assert len(calls) == 2                                             # no folder: no journal
