"""What a diagnosis cannot do with a data file: the data checks' findings (physics.checks) that
break model criticism even where an identification could still run.

- **No rest at the start** (``not-at-rest``; ``ground`` as a warning: fewer than three nodes seen
  at rest): the floor's tilt and height are read from the resting robot (physics.ground). Without
  them a sloped floor, the end caps' contact height and a vertical marker offset cannot be told
  apart, and the slope's fit has no start (GroundSlope.start).
- **Jumping markers** (``jumps``): the effect search scores squared residuals summed over open-loop
  windows; one marker glitch of a few centimetres outweighs every physical effect, and whichever
  effect bends the prediction toward it would be credited.

:func:`require_diagnosable` raises :class:`~physics.findings.DataCheckError` with one line per
file and limit, naming what the diagnosis cannot do and the fix; ``--skip-checks`` skips it.
"""
from __future__ import annotations

from collections.abc import Sequence

from physics.findings import DataCheckError, DataReport

__all__ = ["LIMITS", "diagnosis_limits", "require_diagnosable"]

#: finding code -> what the diagnosis cannot do when a file has it (as a warning or an error)
LIMITS: dict[str, str] = {
    "not-at-rest": "the robot does not start at rest on a floor, so the floor's tilt and height cannot be read: "
                   "a sloped floor, the end caps' contact and a vertical marker offset cannot be told apart",
    "ground": "fewer than three nodes are seen at rest, so the floor's tilt and height cannot be read: a sloped "
              "floor, the end caps' contact and a vertical marker offset cannot be told apart",
    "jumps": "markers jump: a glitch of a few centimetres outweighs every physical effect in the squared "
             "residual, and an effect that bends the prediction toward it would be credited",
}


def diagnosis_limits(report: DataReport) -> list[str]:
    """One line per finding of ``report`` in :data:`LIMITS` (warnings and errors): the source, what
    the diagnosis cannot do, what the check saw and its fix."""
    where = f"{report.source}: " if report.source else ""
    return [f"{where}diagnose cannot use this file: {LIMITS[f.code]} ({f.message} Fix: {f.fix})"
            for f in report.findings if f.code in LIMITS and f.severity in ("error", "warning")]


def require_diagnosable(reports: Sequence[DataReport]) -> None:
    """Raise DataCheckError with every line of :func:`diagnosis_limits` over ``reports``, if any."""
    lines = [line for report in reports for line in diagnosis_limits(report)]
    if lines:
        raise DataCheckError("\n".join([*lines, "Pass --skip-checks to diagnose anyway."]))
