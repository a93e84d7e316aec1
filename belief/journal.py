"""SQLite journal of an identification run (stdlib ``sqlite3``).

Every evaluation (batch, cell, z, θ, E, seconds, status, message, segment errors) is committed (``synchronous=FULL``)
before the next one starts, so a run killed at any point loses at most the evaluation in flight.
The journal also stores the problem's *fingerprint* (parameter space, decoder, grid, seed, proposer,
batch size, initial design size, surrogate options, objective fingerprint when the objective has
one). Opening a journal written for another problem (or by another schema) raises
:class:`JournalMismatchError` naming the keys that differ: the API never discards evaluations on
its own. :func:`set_aside` renames such a journal (``journal.sqlite`` -> ``journal.1.sqlite``) and
:func:`run_with_journals` does it for the command line, which starts afresh unless the user asked to
resume. Budgets are not part of the fingerprint, so a finished run can be extended. Opening a
journal that holds evaluations logs "resuming from N journalled evaluations" (logger
``belief.journal``, level INFO).

Resuming is exact because ``belief.identify`` chooses every batch as a deterministic function of the
seed and of the history before that batch: it replays the journal, recomputes the unfinished
batch (if any) and continues.

Floats are stored as JSON text (``repr`` round-trips IEEE doubles exactly).
"""
from __future__ import annotations

import json
import logging
import math
import os
import sqlite3
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, TypeVar

from belief.errors import JournalError
from physics.objective import STATUSES

__all__ = ["Journal", "JournalMismatchError", "Record", "run_with_journals", "set_aside"]

_SCHEMA_VERSION = 2
_log = logging.getLogger(__name__)
T = TypeVar("T")


class JournalMismatchError(JournalError):
    """The journal at ``path`` was written for another problem or by another schema version: it
    cannot be resumed, and a new run needs another path (or the old file set aside, :func:`set_aside`)."""

    def __init__(self, message: str, path: str, reason: str) -> None:
        super().__init__(message)
        self.path, self.reason = path, reason


@dataclass(frozen=True)
class Record:
    """One evaluation: ``z`` (d), ``theta`` (D), error E (NaN unless ok), wall ``seconds``,
    ``status`` (physics.objective.STATUSES: "ok", "diverged", "failed"), ``message`` (why not ok),
    ``batch`` and ``cell`` indices, ``parts`` (S,) the errors of the objective's segments (NaN unless ok)."""

    batch: int
    cell: int
    z: tuple[float, ...]
    theta: tuple[float, ...]
    error: float
    seconds: float
    status: str
    message: str = ""
    parts: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise JournalError(f"Record.status must be one of {STATUSES}, got {self.status!r}.")


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))


def _diff(a: Any, b: Any, prefix: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out: list[str] = []
        for k in sorted(set(a) | set(b)):
            out += _diff(a.get(k, "<missing>"), b.get(k, "<missing>"), f"{prefix}{k}.")
        return out
    return [] if _canonical(a) == _canonical(b) else [prefix.rstrip(".")]


class Journal:
    """Append-only evaluation log in an SQLite file at ``path`` for the problem ``fingerprint`` (JSON-able dict)."""

    def __init__(self, path: str | os.PathLike[str], fingerprint: dict[str, Any]) -> None:
        self.path = os.fspath(path)
        self.fingerprint = json.loads(_canonical(fingerprint))
        try:
            self._con = sqlite3.connect(self.path, isolation_level=None)
            self._con.execute("PRAGMA synchronous=FULL")
            self._con.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
            self._con.execute(
                "CREATE TABLE IF NOT EXISTS evaluations (idx INTEGER PRIMARY KEY, batch INTEGER NOT NULL, "
                "cell INTEGER NOT NULL, z TEXT NOT NULL, theta TEXT NOT NULL, error REAL, "
                "seconds REAL NOT NULL, status TEXT NOT NULL, message TEXT NOT NULL, parts TEXT NOT NULL)"
            )
            row = self._con.execute("SELECT value FROM meta WHERE key='fingerprint'").fetchone()
        except sqlite3.DatabaseError as exc:
            raise JournalError(f"{self.path!r} is not a tensegrid journal (SQLite error: {exc}); "
                               "pass another path.") from None
        if row is None:
            with self._transaction():
                self._con.execute("INSERT INTO meta VALUES ('fingerprint', ?)", (_canonical(self.fingerprint),))
                self._con.execute("INSERT INTO meta VALUES ('schema', ?)", (str(_SCHEMA_VERSION),))
        else:
            schema = self._con.execute("SELECT value FROM meta WHERE key='schema'").fetchone()
            if schema is None or int(schema[0]) != _SCHEMA_VERSION:
                self._con.close()
                raise JournalMismatchError(
                    f"journal {self.path!r} has schema {None if schema is None else schema[0]}, this version writes "
                    f"{_SCHEMA_VERSION} (segment errors per evaluation); use a new journal path.", self.path,
                    f"schema {None if schema is None else schema[0]}, not {_SCHEMA_VERSION}",
                )
            stored = json.loads(row[0])
            if _canonical(stored) != _canonical(self.fingerprint):
                keys = _diff(stored, self.fingerprint)
                self._con.close()
                raise JournalMismatchError(
                    f"journal {self.path!r} was written by a different problem (differs in: {', '.join(keys)}); "
                    "resume it with the same space, decoder, grid, seed, proposer and options, or use a new journal "
                    "path.", self.path, f"differs in: {', '.join(keys)}",
                )
        if len(self):
            _log.info("resuming from %d journalled evaluations (%s)", len(self), self.path)

    def _transaction(self) -> sqlite3.Connection:
        class _Tx:
            def __init__(s, con: sqlite3.Connection) -> None:
                s.con = con

            def __enter__(s) -> sqlite3.Connection:
                s.con.execute("BEGIN IMMEDIATE")
                return s.con

            def __exit__(s, et: Any, ev: Any, tb: Any) -> None:
                s.con.execute("COMMIT" if et is None else "ROLLBACK")

        return _Tx(self._con)  # type: ignore[return-value]

    def records(self) -> list[Record]:
        """All committed evaluations in order."""
        rows = self._con.execute(
            "SELECT batch, cell, z, theta, error, seconds, status, message, parts FROM evaluations ORDER BY idx"
        ).fetchall()
        return [
            Record(int(b), int(c), tuple(json.loads(z)), tuple(json.loads(t)),
                   float("nan") if e is None else float(e), float(s), str(st), str(msg),
                   tuple(float("nan") if v is None else float(v) for v in json.loads(pa)))
            for b, c, z, t, e, s, st, msg, pa in rows
        ]

    def __iter__(self) -> Iterator[Record]:
        return iter(self.records())

    def __len__(self) -> int:
        return int(self._con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0])

    def append(self, record: Record) -> None:
        """Commit one evaluation (durable when this returns)."""
        err = None if not math.isfinite(record.error) else float(record.error)
        with self._transaction():
            self._con.execute(
                "INSERT INTO evaluations (batch, cell, z, theta, error, seconds, status, message, parts) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (record.batch, record.cell, json.dumps([float(v) for v in record.z]),
                 json.dumps([float(v) for v in record.theta]), err, float(record.seconds),
                 record.status, record.message,
                 json.dumps([float(v) if math.isfinite(v) else None for v in record.parts])),
            )

    def close(self) -> None:
        self._con.close()

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def set_aside(path: str | os.PathLike[str]) -> str:
    """Rename the journal at ``path`` (and its SQLite side files) to the first free
    ``<stem>.<k><ext>`` (journal.sqlite -> journal.1.sqlite, journal.2.sqlite, ...), keeping its
    evaluations readable while freeing ``path`` for a new run; returns the new path."""
    path = os.fspath(path)
    stem, ext = os.path.splitext(path)
    k = 1
    while os.path.lexists(f"{stem}.{k}{ext}"):
        k += 1
    target = f"{stem}.{k}{ext}"
    try:
        os.rename(path, target)
        for side in ("-wal", "-shm", "-journal"):
            if os.path.lexists(path + side):
                os.rename(path + side, target + side)
    except OSError as exc:
        raise JournalError(f"cannot set the journal {path!r} aside as {target!r} ({exc.strerror or exc}); "
                           "move or delete it by hand.") from None
    return target


class _Say(logging.Handler):
    """Passes each distinct message of the ``belief.journal`` logger to ``say``."""

    def __init__(self, say: Callable[[str], None]) -> None:
        super().__init__(logging.INFO)
        self.say, self.seen = say, set[str]()

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        if text not in self.seen:
            self.seen.add(text)
            self.say(text)


def run_with_journals(run: Callable[[], T], *, resume: bool, say: Callable[[str], None], attempts: int = 8) -> T:
    """``run()`` as the command line runs it. Each journal it resumes is reported through ``say``
    ("resuming from N journalled evaluations (PATH)"). A journal of another problem stops ``run``
    before anything is evaluated into it (:class:`JournalMismatchError`); unless ``resume`` (the
    user asked to continue that journal: then it is the error), it is set aside (:func:`set_aside`,
    reported) and ``run()`` is called again, replaying the journals it had already opened, so a
    corrected re-run in the same folder is never blocked by the failed one."""
    handler, level = _Say(say), _log.level
    _log.addHandler(handler)
    _log.setLevel(logging.INFO)
    try:
        for _ in range(attempts):
            try:
                return run()
            except JournalMismatchError as exc:
                if resume:
                    raise JournalMismatchError(f"{exc} --resume keeps it; drop --resume to set it aside and start "
                                               "afresh.", exc.path, exc.reason) from None
                moved = set_aside(exc.path)
                say(f"journal {exc.path} was written by another problem ({exc.reason}); set aside as {moved}, "
                    "starting a new one")
        raise JournalError(f"the run kept meeting journals of another problem after {attempts} set aside; "
                           "give a new output folder.")
    finally:
        _log.removeHandler(handler)
        _log.setLevel(level)
