"""The SQLite journal: durable per evaluation, refuses another problem, exact resume after SIGKILL."""
from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from belief import Grid, Journal, JournalError, PosteriorConfig, Record, identify
from embeddings import Identity
from physics.objective import BatchResult, evaluate_row
from physics.push import PushObjective

HIST_VARS = ("z", "theta", "error", "status", "cell", "batch")


def _same_history(a, b) -> bool:
    return all(np.array_equal(a[v].values, b[v].values, equal_nan=(v in ("error", "z", "theta"))) for v in HIST_VARS)


def test_records_roundtrip_exactly(tmp_path) -> None:
    path = tmp_path / "j.sqlite"
    rec = Record(0, 3, (0.1, 1 / 3), (1.0000000000000002, 0.3), 0.1 + 0.2, 0.5, "ok", "")
    bad = Record(1, 4, (0.2, 0.4), (1.2, 0.4), float("nan"), 0.1, "failed", "PhysicsError: boom")
    with Journal(path, {"a": 1}) as j:
        j.append(rec)
        j.append(bad)
    with Journal(path, {"a": 1}) as j:
        got = j.records()
    assert got[0] == rec and len(got) == 2
    assert np.isnan(got[1].error) and got[1].message == "PhysicsError: boom" and got[1].status == "failed"
    with pytest.raises(JournalError, match="status"):
        Record(0, 0, (), (), 0.0, 0.0, "maybe")


def test_refuses_a_journal_of_another_problem(tmp_path, push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=11)
    path = tmp_path / "j.sqlite"
    identify(obj, dec, grid, budget=6, seed=0, journal=path, progress=False)
    with pytest.raises(JournalError, match=r"different problem \(differs in: proposer.initial.seed, proposer.seed, seed\)"):
        identify(obj, dec, grid, budget=6, seed=1, journal=path, progress=False)
    with pytest.raises(JournalError, match="grid.points_per_dim"):
        identify(obj, dec, Grid.for_decoder(dec, points_per_dim=12), budget=6, seed=0, journal=path, progress=False)
    other, _ = push_problem(seed=5)
    with pytest.raises(JournalError, match="objective.data_sha256"):
        identify(other, dec, grid, budget=6, seed=0, journal=path, progress=False)
    with pytest.raises(JournalError, match="proposer.kind"):
        identify(obj, dec, grid, budget=6, seed=0, journal=path, progress=False, proposer="random")
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"this is not a database at all" * 100)
    with pytest.raises(JournalError, match="not a tensegrid journal"):
        identify(obj, dec, grid, budget=6, seed=0, journal=junk, progress=False)


def test_each_evaluation_is_committed_before_the_next_starts(tmp_path, push_problem) -> None:
    obj, _ = push_problem()
    path = tmp_path / "j.sqlite"
    seen: list[int] = []

    def spy(theta: np.ndarray) -> float:
        if os.path.exists(path):
            with sqlite3.connect(path) as con:
                seen.append(con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0])
        return obj(theta)

    dec = Identity(obj.space)
    identify(spy, dec, Grid.for_decoder(dec, points_per_dim=11), budget=8, seed=0, journal=path,
             posterior=PosteriorConfig(noise_var=0.0025), progress=False)
    assert seen == list(range(8))


def test_resume_after_an_interruption_mid_batch(tmp_path, push_problem) -> None:
    """A crash inside a q = 3 batch: resuming recomputes the same batch and finishes it."""
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=21)
    ref = identify(obj, dec, grid, budget=14, q=3, seed=2, progress=False, posterior=None)
    calls = {"n": 0}

    def crashing(theta: np.ndarray) -> float:
        calls["n"] += 1
        if calls["n"] == 10:  # the 2nd evaluation of batch 2
            raise KeyboardInterrupt
        return obj(theta)

    path = tmp_path / "j.sqlite"
    kw = dict(budget=14, q=3, seed=2, progress=False, posterior=None, journal=path)
    with pytest.raises(KeyboardInterrupt):
        identify(crashing, dec, grid, **kw)
    with sqlite3.connect(path) as con:
        assert con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0] == 9
    res = identify(lambda th: obj(th), dec, grid, **kw)
    assert _same_history(res.history, ref.history)


class _StreamingBatch(PushObjective):
    """The push objective with a batch that finishes its rows in reverse order, streams them through
    ``on_result`` and can be 'killed' (KeyboardInterrupt) after ``kill_after`` rows of one batch."""

    kill_after: int | None = None

    def evaluate_batch(self, thetas, *, on_result=None):
        rows = [None] * len(thetas)
        for n, k in enumerate(reversed(range(len(thetas)))):
            if self.kill_after is not None and n == self.kill_after:
                raise KeyboardInterrupt
            rows[k] = evaluate_row(self, thetas[k])
            if on_result is not None:
                on_result(k, *rows[k])
        return BatchResult.from_rows(rows, len(self.segments))


def _streaming(obj, cls=_StreamingBatch, kill_after=None):
    out = cls(obj.impulses, obj.observed, noise_std=obj.noise_std)
    out.kill_after = kill_after
    return out


def test_a_parallel_batch_is_journalled_row_by_row_and_resumes_its_missing_cells(tmp_path, push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=21)
    kw = dict(budget=12, q=4, n_init=4, seed=5, progress=False, posterior=None)
    ref = identify(_streaming(obj), dec, grid, **kw)
    path = tmp_path / "j.sqlite"
    with pytest.raises(KeyboardInterrupt):
        identify(_streaming(obj, kill_after=3), dec, grid, journal=path, **kw)  # dies in the first batch
    with sqlite3.connect(path) as con:
        assert con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0] == 3
    calls = []

    class Counting(_StreamingBatch):
        def evaluate_batch(self, thetas, *, on_result=None):
            calls.append(len(thetas))
            return super().evaluate_batch(thetas, on_result=on_result)

    res = identify(_streaming(obj, Counting), dec, grid, journal=path, **kw)
    assert calls == [4, 4]  # the one missing cell of batch 0 by a plain call, then batches 1 and 2 whole
    assert _same_history(res.history, ref.history)


def test_extend_a_finished_run(tmp_path, push_problem) -> None:
    obj, _ = push_problem()
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=21)
    path = tmp_path / "j.sqlite"
    identify(obj, dec, grid, budget=8, seed=0, journal=path, progress=False)
    ext = identify(obj, dec, grid, budget=12, seed=0, journal=path, progress=False)
    ref = identify(obj, dec, grid, budget=12, seed=0, progress=False)
    assert _same_history(ext.history, ref.history)
    assert np.array_equal(ext.posterior.values, ref.posterior.values)


_SCRIPT = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from physics.push import PushObjective, generate_push_data
    from embeddings import Identity
    from belief import Grid, PosteriorConfig, identify

    J, S = generate_push_data([1.0, 0.4], n=8, noise_std=0.05, seed=0)
    obj = PushObjective(J, S, noise_std=0.05)

    def slow(theta):
        time.sleep(float(sys.argv[2]))
        return obj(theta)

    dec = Identity(obj.space)
    identify(slow, dec, Grid.for_decoder(dec, points_per_dim=21), budget=16, seed=7, journal=sys.argv[1],
             posterior=PosteriorConfig(noise_var=0.0025), progress=False)
    """
)


def test_sigkill_midway_then_resume_gives_the_uninterrupted_history(tmp_path) -> None:
    from physics.push import PushObjective, generate_push_data

    script = tmp_path / "run.py"
    script.write_text(_SCRIPT)
    path = tmp_path / "killed.sqlite"
    env = dict(os.environ, PYTHONPATH=os.getcwd() + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, str(script), str(path), "0.15"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    n = 0
    deadline = time.time() + 120
    try:
        while time.time() < deadline:
            if proc.poll() is not None:
                pytest.fail(f"worker exited early: {proc.stderr.read().decode()[-2000:]}")
            if path.exists():
                try:
                    with sqlite3.connect(path, timeout=0.1) as con:
                        n = con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0]
                except sqlite3.OperationalError:
                    n = 0
            if n >= 8:
                break
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL and 8 <= n < 16

    J, S = generate_push_data([1.0, 0.4], n=8, noise_std=0.05, seed=0)
    obj = PushObjective(J, S, noise_std=0.05)
    dec = Identity(obj.space)
    grid = Grid.for_decoder(dec, points_per_dim=21)
    kw = dict(budget=16, seed=7, posterior=PosteriorConfig(noise_var=0.0025), progress=False)
    resumed = identify(lambda th: obj(th), dec, grid, journal=path, **kw)
    straight = identify(lambda th: obj(th), dec, grid, **kw)
    assert _same_history(resumed.history, straight.history)
    assert np.array_equal(resumed.posterior.values, straight.posterior.values)


def test_a_mismatch_names_its_path_and_set_aside_frees_it(tmp_path) -> None:
    """The API keeps refusing another problem's journal; set_aside renames it (journal.1, journal.2, ...)."""
    from belief.journal import JournalMismatchError, set_aside

    path = tmp_path / "journal.sqlite"
    rec = Record(0, 0, (0.5,), (1.0,), 2.0, 0.1, "ok")
    for k in (1, 2):
        with Journal(path, {"a": 1}) as j:
            j.append(rec)
        with pytest.raises(JournalMismatchError, match=r"differs in: a\)") as caught:
            Journal(path, {"a": 2})
        assert caught.value.path == str(path) and caught.value.reason == "differs in: a"
        assert isinstance(caught.value, JournalError)
        assert set_aside(path) == str(tmp_path / f"journal.{k}.sqlite") and not path.exists()
    with Journal(tmp_path / "journal.1.sqlite", {"a": 1}) as kept:
        assert kept.records() == [rec]


def test_run_with_journals_sets_aside_reports_resumes_and_respects_resume(tmp_path) -> None:
    from belief.journal import JournalMismatchError, run_with_journals

    path = tmp_path / "j.sqlite"
    with Journal(path, {"a": 1}) as j:
        j.append(Record(0, 0, (0.5,), (1.0,), 2.0, 0.1, "ok"))
    said: list[str] = []

    def run(fingerprint: dict) -> int:
        with Journal(path, fingerprint) as j:
            return len(j)

    assert run_with_journals(lambda: run({"a": 1}), resume=True, say=said.append) == 1
    assert said == [f"resuming from 1 journalled evaluations ({path})"]
    with pytest.raises(JournalMismatchError, match="drop --resume to set it aside"):
        run_with_journals(lambda: run({"a": 2}), resume=True, say=said.append)
    assert path.exists() and not (tmp_path / "j.1.sqlite").exists()
    assert run_with_journals(lambda: run({"a": 2}), resume=False, say=said.append) == 0
    assert said[-1] == f"journal {path} was written by another problem (differs in: a); set aside as " \
                       f"{tmp_path / 'j.1.sqlite'}, starting a new one"
