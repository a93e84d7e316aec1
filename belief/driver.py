"""The identification driver: budgets, journal, replay and evaluation around any proposer.

::

    replay the carried records (evaluations of an earlier stage) and the journal (records of
    earlier sessions), each checked against the grid
    for batch b = 0, 1, ...:                       until the budget (evaluations, seconds) is spent
        size = n_init (b = 0) or q
        cells = proposer.propose(b, records of batches < b, size, grid)
        skip the cells the journal already holds for batch b (else: the replay diverged -> error)
        evaluate θ = decoder(z) of the others; journal each row as soon as it finishes
    return the records (ordered by batch, then cell) and why the loop stopped

Evaluation: ``objective.evaluate_batch(thetas, on_result=...)`` for batches when the objective has
it (physics.objective contract: rows stream in completion order, with segment errors); else one
call per θ, on ``workers`` threads. Statuses follow physics.objective.STATUSES: a
:class:`PhysicsError` is "diverged", a non-finite error or a batch row not "ok" is "failed".

Time budget: the journalled seconds of replayed evaluations plus this session's wall time,
checked before each batch and, serially, before each evaluation.
"""
from __future__ import annotations

import concurrent.futures as cf
import inspect
import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
from tqdm.auto import tqdm

from belief.errors import JournalError, ObjectiveError
from belief.journal import Journal, Record
from belief.proposers import Proposal, Proposer
from physics.errors import PhysicsError

__all__ = ["Budget", "DriverResult", "run"]

#: (error, status, message, seconds, parts): one evaluated row
_Row = tuple[float, str, str, float, tuple[float, ...]]


@dataclass(frozen=True)
class Budget:
    """Evaluations to reach (``n_target``), seconds (``seconds``, or None), initial design size and batch size."""

    n_target: int
    seconds: float | None
    n_init: int
    q: int


@dataclass
class DriverResult:
    """Every record (by batch, then cell), why the loop stopped ("budget", "time", "exhausted")."""

    records: list[Record]
    stopped: str


def _as_error(value: Any) -> float:
    if isinstance(value, (tuple, list)) and len(value) == 2 and isinstance(value[1], str):
        value = value[0]
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ObjectiveError(
            f"objective must return a scalar error (float), got {type(value).__name__}: {value!r}."
        ) from None
    if arr.shape != ():
        raise ObjectiveError(f"objective must return a scalar error, got an array of shape {arr.shape}; sum it.")
    return float(arr)


def _call_one(objective: Any, theta: np.ndarray) -> _Row:
    """One evaluation: ``evaluate_parts`` when the objective has it (E = Σ parts), else the call."""
    t0 = time.perf_counter()
    parts_fn = getattr(objective, "evaluate_parts", None)
    try:
        if callable(parts_fn):
            parts = tuple(float(v) for v in np.asarray(parts_fn(theta), dtype=float).ravel())
            err = float(sum(parts))
        else:
            err = _as_error(objective(theta))
            parts = (err,)
    except PhysicsError as exc:
        return float("nan"), "diverged", f"{type(exc).__name__}: {exc}", time.perf_counter() - t0, ()
    dt = time.perf_counter() - t0
    if not math.isfinite(err):
        return float("nan"), "failed", f"objective returned a non-finite error ({err!r})", dt, ()
    return err, "ok", "", dt, parts


def _legacy_row(item: Any, seconds: float, message: str) -> _Row:
    """A row of an evaluate_batch without the contract: an error or an (error, status) pair."""
    status = item[1] if isinstance(item, (tuple, list)) and len(item) == 2 and isinstance(item[1], str) else "ok"
    value = _as_error(item)
    if status != "ok" or not math.isfinite(value):
        return (float("nan"), "failed", f"evaluate_batch status {status!r}, error {value!r}"
                + (f": {message}" if message else ""), float(seconds), ())
    return value, "ok", "", float(seconds), (value,)


def _accepts_on_result(fn: Callable[..., Any]) -> bool:
    try:
        return "on_result" in inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return False


def _evaluate_batch(objective: Any, thetas: np.ndarray, commit: Callable[[int, _Row], None]) -> None:
    """Evaluate rows with ``objective.evaluate_batch``; ``commit(k, row)`` each as soon as it is known."""
    if _accepts_on_result(objective.evaluate_batch):
        def stream(k: int, err: float, status: str, seconds: float, message: str, parts: Any) -> None:
            if status == "ok" and not math.isfinite(err):
                status, message = "failed", f"objective returned a non-finite error ({err!r})"
            ok = status == "ok"
            commit(int(k), (float(err) if ok else float("nan"), status, str(message), float(seconds),
                            tuple(float(v) for v in parts) if ok else ()))

        objective.evaluate_batch(thetas, on_result=stream)
        return
    t0 = time.perf_counter()
    raw_obj = objective.evaluate_batch(thetas)
    raw = list(raw_obj)
    if len(raw) != len(thetas):
        raise ObjectiveError(f"objective.evaluate_batch returned {len(raw)} results for {len(thetas)} thetas.")
    even = (time.perf_counter() - t0) / len(thetas)
    seconds = getattr(raw_obj, "seconds", None)
    messages = getattr(raw_obj, "messages", None)
    for k, item in enumerate(raw):
        sec = float(seconds[k]) if seconds is not None and len(seconds) == len(raw) else even
        why = str(messages[k]) if messages is not None and len(messages) == len(raw) and messages[k] else ""
        commit(k, _legacy_row(item, sec, why))


def _evaluate(objective: Any, thetas: np.ndarray, commit: Callable[[int, _Row], None], *, workers: int,
              out_of_time: Callable[[], bool]) -> bool:
    """Evaluate a batch; returns True if the time budget stopped a serial batch early."""
    if len(thetas) > 1 and callable(getattr(objective, "evaluate_batch", None)):
        _evaluate_batch(objective, thetas, commit)
    elif len(thetas) > 1 and workers > 1:
        with cf.ThreadPoolExecutor(max_workers=int(workers)) as ex:
            for k, fut in enumerate([ex.submit(_call_one, objective, th) for th in thetas]):
                commit(k, fut.result())
    else:
        for k, th in enumerate(thetas):
            if k > 0 and out_of_time():
                return True
            commit(k, _call_one(objective, th))
    return False


def _replayed(journal: Journal | None, grid: Any, n_target: int | None, carried: Sequence[Record] = ()) -> list[Record]:
    """The carried records, then the journal's, each checked against its grid cell."""
    records = list(carried) + (journal.records() if journal is not None else [])
    points = np.asarray(grid.points)
    for k, r in enumerate(records):
        if not (0 <= r.cell < grid.size) or not np.array_equal(np.asarray(r.z), points[r.cell]):
            where = "carried evaluations" if k < len(carried) else f"journal {getattr(journal, 'path', None)!r}"
            raise JournalError(f"{where}: evaluation of cell {r.cell} does not match the grid.")
    return records[:n_target] if n_target is not None else records


def run(objective: Any, decoder: Any, grid: Any, proposer: Proposer, budget: Budget, *, journal: Journal | None,
        workers: int = 1, progress: bool = True, label: str = "identify",
        after_batch: Callable[[int, Sequence[Record], Proposal], None] | None = None,
        carried: Sequence[Record] = ()) -> DriverResult:
    """Run the loop of the module docstring; ``after_batch(n_before, history, proposal)`` is called
    before each batch is evaluated (e.g. to report P). ``carried``: evaluations made before this run
    (belief.handoff), replayed before the journal's and never journalled."""
    records = _replayed(journal, grid, budget.n_target, carried)
    points = np.asarray(grid.points)
    t_start, replayed = time.perf_counter(), float(sum(r.seconds for r in records))
    out_of_time = lambda: budget.seconds is not None and replayed + time.perf_counter() - t_start >= budget.seconds  # noqa: E731
    bar = tqdm(total=budget.n_target, initial=len(records), disable=not progress, desc=label, leave=False)
    b, stopped = 0, "budget"
    best = [min([r.error for r in records if r.status == "ok"], default=math.inf)]
    while True:
        n_before = sum(1 for r in records if r.batch < b)
        if n_before >= budget.n_target or n_before >= grid.size:
            stopped = "budget" if n_before >= budget.n_target else "exhausted"
            break
        size = min(budget.n_init if b == 0 else budget.q, budget.n_target - n_before, grid.size - n_before)
        done = {r.cell for r in records if r.batch == b}
        if len(done) >= size:
            b += 1
            continue
        if out_of_time():
            stopped = "time"
            break
        hist = [r for r in records if r.batch < b]
        proposal = proposer.propose(b, hist, size, grid)
        if not done <= set(proposal.cells):
            raise JournalError(f"journal {getattr(journal, 'path', None)!r} diverges from the deterministic replay at "
                               f"batch {b}; it was written by another version or options. Use a new journal path.")
        todo = [c for c in proposal.cells if c not in done]
        zs, thetas = points[todo], decoder.decode(points[todo])
        if after_batch is not None:
            after_batch(n_before, hist, proposal)

        def commit(k: int, row: _Row, b: int = b) -> None:
            rec = Record(b, int(todo[k]), tuple(float(v) for v in zs[k]), tuple(float(v) for v in thetas[k]),
                         row[0], row[3], row[1], row[2], row[4])
            if journal is not None:
                journal.append(rec)
            records.append(rec)
            bar.update(1)
            if rec.status == "ok":
                best[0] = min(best[0], rec.error)
                bar.set_postfix(best=f"{best[0]:.4g}", refresh=False)

        if _evaluate(objective, thetas, commit, workers=workers, out_of_time=out_of_time):
            stopped = "time"
            break
        b += 1
    bar.close()
    records.sort(key=lambda r: (r.batch, r.cell))
    return DriverResult(records, stopped)
