"""The mismatch stage's journal: an interrupted diagnose resumes without repeating the stage.

The stage (:func:`criticism.mismatch.absorb_mismatch`, minutes of least squares) is written, when
it ends, to ``mismatch_stage.json`` in the diagnose's journal folder, next to the identification
journals: its report (:meth:`MismatchReport.as_dict`) under the fingerprint of the problem it
solved, i.e. the objective's fingerprint (data, horizon, windows, model), the held-out
trajectories and the stage's settings (:meth:`MismatchConfig.record`). A later diagnose in the
same folder reads the report back when the fingerprints are equal, and raises
:class:`belief.journal.JournalMismatchError` when they differ, as an identification journal does
(the command line then sets the file aside, unless ``--resume``). The file is written whole, by
renaming a finished temporary file, so an interruption never leaves half a stage behind.
"""
from __future__ import annotations

import json
import logging
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from belief.journal import JournalMismatchError
from criticism.mismatch import MismatchConfig, MismatchReport, absorb_mismatch
from physics.trajectory_objective import TrajectoryObjective

__all__ = ["STAGE_JOURNAL", "FORMAT", "stage_fingerprint", "journalled_stage"]

#: file name of the stage's journal in a diagnose's journal folder
STAGE_JOURNAL = "mismatch_stage.json"
#: schema of the file
FORMAT = "tensegrid.mismatch-stage/1"

_log = logging.getLogger("belief.journal")       # the channel the command line reports resumed journals on


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))


def stage_fingerprint(objective: TrajectoryObjective, held: Sequence[int], config: MismatchConfig,
                      theta: np.ndarray | None = None) -> dict[str, Any]:
    """What identifies a stage: the objective's fingerprint, the held-out trajectories, the settings
    and the start θ0 when one is given."""
    record = {"format": FORMAT, "objective": objective.fingerprint(), "held": [int(k) for k in held],
              "config": config.record()}
    if theta is not None:
        record["theta"] = [float(v) for v in theta]
    return json.loads(_canonical(record))


def _read(path: Path, fingerprint: dict[str, Any]) -> MismatchReport | None:
    """The journalled report, None if there is none; JournalMismatchError if it is of another problem."""
    if not path.exists():
        return None
    try:
        saved = json.loads(path.read_text())
        same = _canonical(saved["fingerprint"]) == _canonical(fingerprint)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise JournalMismatchError(f"the stage journal {path} cannot be read ({exc}).", os.fspath(path),
                                   "unreadable stage journal") from None
    if not same:
        raise JournalMismatchError(f"the stage journal {path} was written for another problem (data, held-out "
                                   "trajectories or stage settings differ).", os.fspath(path), "another stage")
    _log.info("resuming the mismatch stage from its journal (%s)", path)
    return MismatchReport.from_dict(saved["report"])


def _write(path: Path, fingerprint: dict[str, Any], report: MismatchReport) -> None:
    temporary = path.with_name(path.name + ".partial")
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary.write_text(json.dumps({"fingerprint": fingerprint, "report": report.as_dict()}))
    os.replace(temporary, path)


def journalled_stage(objective: TrajectoryObjective, fit: np.ndarray, held: Sequence[int], *,
                     config: MismatchConfig, journal_dir: Path | None, progress: bool = True,
                     theta: np.ndarray | None = None) -> MismatchReport:
    """:func:`absorb_mismatch` (``objective``, ``fit`` mask (S,), ``held`` trajectory indices, start
    ``theta`` (D,), default the nominal θ), read from ``journal_dir``/STAGE_JOURNAL when a stage of
    the same problem is there, written there after."""
    if journal_dir is None:
        return absorb_mismatch(objective, fit, held, theta=theta, config=config, progress=progress)
    path = Path(journal_dir) / STAGE_JOURNAL
    fingerprint = stage_fingerprint(objective, held, config, theta)
    report = _read(path, fingerprint)
    if report is None:
        report = absorb_mismatch(objective, fit, held, theta=theta, config=config, progress=progress)
        _write(path, fingerprint, report)
    return report
