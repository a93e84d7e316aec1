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

Evaluation (physics.objective contract): a batch of several cells is
``objective.evaluate_batch(thetas, on_result=...)``, whose rows are journalled as they stream in
(completion order); a one-cell batch is :func:`physics.objective.evaluate_row` in this process.
Both map outcomes to physics.objective.STATUSES the same way: a :class:`PhysicsError` is
"diverged", another tensegrid error or a non-finite error is "failed", a bug propagates.
Plain functions θ -> E are wrapped in :class:`physics.objective.FunctionObjective` before they
reach the driver (belief.identify), so it sees only the contract.

Time budget: the journalled seconds of replayed evaluations plus this session's wall time,
checked before each batch.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from belief.errors import JournalError, ObjectiveError
from belief.grid import CandidateSet
from belief.journal import Journal, Record
from belief.proposers import Proposal, Proposer
from embeddings.base import Decoder
from physics.objective import STATUSES, Objective, Row, evaluate_row

__all__ = ["Budget", "DriverResult", "run"]

#: commit(k, row): journal row k of the batch being evaluated
Commit = Callable[[int, Row], None]


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


def _checked(k: int, row: Row) -> Row:
    """Row k of a batch, with an "ok" row whose error is not finite made "failed" (E must be a number)."""
    error, status, seconds, message, parts = row
    if status not in STATUSES:
        raise ObjectiveError(f"evaluate_batch reported status {status!r} for row {k}; the physics.objective contract "
                             f"allows {STATUSES} (map other outcomes to 'failed' with a message).")
    if status == "ok" and not math.isfinite(error):
        return math.nan, "failed", seconds, f"objective returned a non-finite error ({error!r})", parts
    return row


def _evaluate(objective: Objective, thetas: np.ndarray, commit: Commit) -> None:
    """Evaluate the rows of θs (n, D), ``commit(k, row)`` each as soon as it is known."""
    if len(thetas) == 1:
        commit(0, _checked(0, evaluate_row(objective, thetas[0])))
        return
    seen: set[int] = set()

    def stream(k: int, error: float, status: str, seconds: float, message: str, parts: np.ndarray) -> None:
        seen.add(int(k))
        commit(int(k), _checked(int(k), (float(error), status, float(seconds), str(message), np.asarray(parts))))

    objective.evaluate_batch(thetas, on_result=stream)
    missing = sorted(set(range(len(thetas))) - seen)
    if missing:
        raise ObjectiveError(f"{type(objective).__name__}.evaluate_batch did not report rows {missing[:5]} of "
                             f"{len(thetas)} through on_result; the physics.objective contract calls on_result(k, ...) "
                             "once per row.")


def _replayed(journal: Journal | None, grid: CandidateSet, n_target: int | None,
              carried: Sequence[Record] = ()) -> list[Record]:
    """The carried records, then the journal's, each checked against its grid cell."""
    records = list(carried) + (journal.records() if journal is not None else [])
    points = np.asarray(grid.points)
    for k, r in enumerate(records):
        if not (0 <= r.cell < grid.size) or not np.array_equal(np.asarray(r.z), points[r.cell]):
            where = "carried evaluations" if k < len(carried) else f"journal {_path(journal)!r}"
            raise JournalError(f"{where}: evaluation of cell {r.cell} does not match the grid.")
    return records[:n_target] if n_target is not None else records


def _path(journal: Journal | None) -> str | None:
    return None if journal is None else journal.path


def _record(batch: int, cell: int, z: np.ndarray, theta: np.ndarray, row: Row) -> Record:
    """The journal record of one evaluated row (error, status, seconds, message, parts); parts only when ok."""
    error, status, seconds, message, parts = row
    ok = status == "ok"
    return Record(batch, int(cell), tuple(float(v) for v in z), tuple(float(v) for v in theta),
                  float(error) if ok else math.nan, float(seconds), status, str(message),
                  tuple(float(v) for v in np.ravel(parts)) if ok else ())


def run(objective: Objective, decoder: Decoder, grid: CandidateSet, proposer: Proposer, budget: Budget, *,
        journal: Journal | None, progress: bool = True, label: str = "identify",
        after_batch: Callable[[int, Sequence[Record], Proposal], None] | None = None,
        carried: Sequence[Record] = ()) -> DriverResult:
    """Run the loop of the module docstring; ``after_batch(n_before, history, proposal)`` is called
    before each batch is evaluated (e.g. to report P). ``carried``: evaluations made before this run
    (belief.handoff), replayed before the journal's and never journalled."""
    records = _replayed(journal, grid, budget.n_target, carried)
    points = np.asarray(grid.points)
    t_start, replayed = time.perf_counter(), float(sum(r.seconds for r in records))
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
        if budget.seconds is not None and replayed + time.perf_counter() - t_start >= budget.seconds:
            stopped = "time"
            break
        hist = [r for r in records if r.batch < b]
        proposal = proposer.propose(b, hist, size, grid)
        if not done <= set(proposal.cells):
            raise JournalError(f"journal {_path(journal)!r} diverges from the deterministic replay at batch {b}; it "
                               "was written by another version or options. Use a new journal path.")
        todo = [c for c in proposal.cells if c not in done]
        zs, thetas = points[todo], np.atleast_2d(decoder.decode(points[todo]))
        if after_batch is not None:
            after_batch(n_before, hist, proposal)

        def commit(k: int, row: Row, b: int = b, todo: list[int] = todo, zs: np.ndarray = zs,
                   thetas: np.ndarray = thetas) -> None:
            rec = _record(b, todo[k], zs[k], thetas[k], row)
            if journal is not None:
                journal.append(rec)
            records.append(rec)
            bar.update(1)
            if rec.status == "ok":
                best[0] = min(best[0], rec.error)
                bar.set_postfix(best=f"{best[0]:.4g}", refresh=False)

        _evaluate(objective, thetas, commit)
        b += 1
    bar.close()
    records.sort(key=lambda r: (r.batch, r.cell))
    return DriverResult(records, stopped)
