"""The findings of the data checks (physics.checks): one typed finding per problem, a report per file.

A :class:`Finding` has a stable ``code``, a ``severity`` (``error``: identification would be
meaningless; ``warning``: it would be biased or weak; ``info``: what the file is), a ``message``
with the numbers and the ``fix``.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from physics.errors import TrajectoryFormatError
from physics.ground import GroundPlane

__all__ = ["Severity", "Finding", "DataReport", "DataCheckError"]

Severity = Literal["error", "warning", "info"]


@dataclass(frozen=True)
class Finding:
    """One thing a check found: ``code`` (a stable name), ``severity``, ``message`` (what it sees,
    with numbers) and ``fix`` (what to do)."""

    code: str
    severity: Severity
    message: str
    fix: str = ""

    def line(self) -> str:
        """``severity code: message Fix: fix`` on one line."""
        return f"{self.severity} {self.code}: {self.message}" + (f" Fix: {self.fix}" if self.fix else "")


@dataclass(frozen=True, eq=False)
class DataReport:
    """The findings of one trajectory and what was measured: ``length_scale`` [m per file unit] and
    ``time_scale`` [s per file unit] as detected, ``rod_length`` the median rod length [m],
    ``sample_interval`` the median interval [s], ``ground`` the plane under the resting robot."""

    findings: tuple[Finding, ...]
    source: str | None = None
    length_scale: float = 1.0
    time_scale: float = 1.0
    rod_length: float = float("nan")
    sample_interval: float = float("nan")
    ground: GroundPlane | None = None

    @property
    def errors(self) -> tuple[Finding, ...]:
        return tuple(f for f in self.findings if f.severity == "error")

    @property
    def warnings(self) -> tuple[Finding, ...]:
        return tuple(f for f in self.findings if f.severity == "warning")

    @property
    def codes(self) -> tuple[str, ...]:
        return tuple(f.code for f in self.findings)

    def finding(self, code: str) -> Finding | None:
        """The first finding with ``code``, or None."""
        return next((f for f in self.findings if f.code == code), None)

    def lines(self, *, severities: Sequence[Severity] = ("error", "warning", "info")) -> list[str]:
        """One line per finding of the given severities, prefixed by the source when known."""
        where = f"{self.source}: " if self.source else ""
        return [where + f.line() for f in self.findings if f.severity in severities]


class DataCheckError(TrajectoryFormatError):
    """A trajectory fails the pre-flight checks (physics.checks); the message has one line per error."""
