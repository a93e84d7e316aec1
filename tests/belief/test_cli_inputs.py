"""Bad command-line inputs of identify, diagnose, plan and probe: each gives its named, typed, one-line
error, leaves nothing half-written, and the corrected re-run works in the same --out. Covers the prior
box (--nominal, --bounds, --params), output paths, budgets, and journals of another problem (set aside
unless --resume)."""
from __future__ import annotations

import argparse
import json
import os
import re
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from belief import IdentificationResult
from belief.journal import Journal, Record
from physics import FlopController, ParameterSpace, save_trajectory, simulate
from physics.cli import main
from physics.errors import ParameterError
from physics.outputs import OutputError, check_output_dir
from physics.prior_box import box_record, prior_box

TOY = ["--toy", "push", "--preset", "bo", "--no-progress"]


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> list[str]:
    """Two 0.3 s SUPERball flops at the nominal θ (toward +x and +y), saved as netCDF."""
    folder = tmp_path_factory.mktemp("data")
    return [str(save_trajectory(simulate(controller=FlopController(heading=h), duration=0.3), folder / f"{k}.nc"))
            for k, h in enumerate((0.0, 1.5708))]


def _count(journal: Path) -> int:
    with sqlite3.connect(journal) as con:
        return int(con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0])


def _error(capsys: pytest.CaptureFixture[str], *needles: str) -> str:
    """The one error line on stderr (notes aside), checked to contain ``needles``."""
    err = capsys.readouterr().err
    assert "Traceback" not in err and "Warning:" not in err, err
    lines = [line for line in err.splitlines() if line.strip() and ": note: " not in line]
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


# ---------------------------------------------------------------------------------------------- output paths
def _bad_outs(tmp_path: Path) -> dict[str, tuple[str, str]]:
    """name -> (--out value, what its error says)."""
    afile = tmp_path / "afile.txt"
    afile.write_text("not a folder")
    return {"empty": ("", "--out is empty"),
            "existing file": (str(afile), "is an existing file, not a folder"),
            "under a file": (str(afile / "sub"), "is a file, so no folder can be made under it"),
            "proc": ("/proc/tensegrid-test/x", "lies in /proc, a virtual file system")}


@pytest.mark.parametrize("command", ["identify", "diagnose", "plan", "probe"])
def test_every_bad_out_is_a_one_line_typed_error(command: str, tmp_path, data, capsys) -> None:
    args = {"identify": ["identify", *TOY, "--budget", "12"], "diagnose": ["diagnose", *data],
            "plan": ["plan", str(tmp_path / "belief.nc"), "--goal", "1", "0"],
            "probe": ["probe", str(tmp_path / "belief.nc")]}[command]
    for name, (out, says) in _bad_outs(tmp_path).items():
        assert main([*args, "--out", out]) == 2, name
        _error(capsys, says, command)
        with pytest.raises(OutputError, match=re.escape(says)):
            check_output_dir(out)
    assert not os.path.exists("/proc/tensegrid-test")
    assert sorted(os.listdir(tmp_path)) == ["afile.txt"]


def test_an_unwritable_out_is_a_one_line_error(tmp_path, monkeypatch, capsys) -> None:
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: False if Path(p) == locked else real(p, mode, **kw))
    assert main(["identify", *TOY, "--budget", "12", "--out", str(locked / "run")]) == 2
    _error(capsys, f"{locked} is not writable")
    assert os.listdir(locked) == []


# --------------------------------------------------------------------------------------------------- budgets
def test_budget_zero_leaves_no_folder_and_the_corrected_run_works(tmp_path, capsys) -> None:
    out = tmp_path / "nested" / "run"
    assert main(["identify", *TOY, "--budget", "0", "--out", str(out)]) == 2
    _error(capsys, "budget must be >= 1", "--budget 0")
    assert not (tmp_path / "nested").exists()
    # refused by the preset once the folder was made: the failed run removes it again
    assert main(["identify", "--toy", "push", "--budget", "6", "--out", str(out), "--no-progress"]) == 2
    _error(capsys, "budget=6 is too small for preset 'handoff-gn'")
    assert not (tmp_path / "nested").exists()
    # the push toy's D = 2: the search makes 12 - (D + 4) = 6, the 6 kept for its assessment
    assert main(["identify", *TOY, "--budget", "12", "--out", str(out)]) == 0
    result = IdentificationResult.load(out / "result.nc")
    assert result.n_evaluations == 6 and result.config["evaluations"]["search"] == 6
    assert result.config["evaluations"]["total"] <= 12


def test_a_budget_within_the_initial_design_is_warned_with_the_numbers(tmp_path, capsys) -> None:
    # the push toy's D = 2: bo keeps D + 4 = 6 of the budget for its assessment, as bo-gn for its step
    assert main(["identify", *TOY, "--budget", "11", "--out", str(tmp_path / "a")]) == 0
    err = capsys.readouterr().err
    assert "--budget 11 leaves 5 evaluations after the 6 of the Gauss-Newton step after it for BO over the full " \
           "space, no more than its initial design of 5 Sobol points: BO never runs" in err
    assert "give --budget 12 or more" in err
    assert main(["identify", *TOY[:3], "bo-gn", "--no-progress", "--budget", "10", "--out", str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert "leaves 4 evaluations after the 6 of the Gauss-Newton step" in err and "give --budget 12 or more" in err
    assert main(["identify", *TOY, "--budget", "12", "--out", str(tmp_path / "c")]) == 0
    assert "BO never runs" not in capsys.readouterr().err


def test_the_t6_budget_of_the_issue_is_warned_before_anything_runs() -> None:
    """--budget 30 with --preset bo on the T6: 11 evaluations for the search after the 19 kept for the
    Gauss-Newton step after it, fewer than the 16-point initial design."""
    from belief.cli import _budget_note, register_identify

    parser = argparse.ArgumentParser(prog="tensegrid")
    register_identify(parser.add_subparsers(dest="command"))
    note = _budget_note(parser.parse_args(["identify", "x.nc", "--preset", "bo", "--budget", "30", "--out", "o"]),
                        None, 15)
    assert note is not None and "initial design of 16 Sobol points" in note and "give --budget 36 or more" in note
    assert "leaves 11 evaluations after the 19 of the Gauss-Newton step" in note
    assert _budget_note(parser.parse_args(["identify", "x.nc", "--preset", "bo", "--budget", "36", "--out", "o"]),
                        None, 15) is None


# ------------------------------------------------------------------------------------------------- prior box
def _params(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def _bad_boxes(tmp_path: Path) -> dict[str, tuple[list[str], str]]:
    """name -> (box options, what the error says)."""
    return {
        "unknown name": (["--nominal", "rod_lenght=2"], "unknown parameter 'rod_lenght'; the known names are "
                                                        "density, radius, density_mp"),
        "lo >= hi": (["--bounds", "rod_length=2.2:1.8"], "lower bound 2.2 must be below upper bound 1.8"),
        "nominal outside": (["--nominal", "rod_length=2.5", "--bounds", "rod_length=1.8:2.2"],
                            "nominal 2.5 lies outside its bounds [1.8, 2.2]"),
        "negative length": (["--nominal", "rod_length=-1.7"], "nominal -1.7 m is not a physical value"),
        "negative bound": (["--bounds", "density=-10:300"], "lower bound -10.0 is non-physical"),
        "not a number": (["--nominal", "damping=lots"], "--nominal damping: 'lots' is not a number"),
        "no colon": (["--bounds", "damping=150"], "--bounds expects NAME=LO:HI"),
        "twice": (["--nominal", "damping=150", "--nominal", "damping=160"], "names 'damping' twice"),
        "no file": (["--params", str(tmp_path / "none.json")], "no such file"),
        "one bound": (["--params", _params(tmp_path, "one.json", '{"rod_length": {"lower": 1.8}}')],
                      "gives one bound"),
        "wrong unit": (["--params", _params(tmp_path, "mm.toml", '[rod_length]\nnominal = 1800\nunit = "mm"\n')],
                       "is in 'mm', the parameter in 'm'"),
        "bad json": (["--params", _params(tmp_path, "bad.json", '{"rod_length": ')], "cannot read it"),
    }


def test_each_bad_prior_box_is_a_one_line_error_then_the_corrected_run_works(tmp_path, data, capsys) -> None:
    out = tmp_path / "run"
    for name, (options, says) in _bad_boxes(tmp_path).items():
        assert main(["identify", data[0], "--preset", "random", "--budget", "21", *options, "--out", str(out),
                     "--no-progress"]) == 2, name
        _error(capsys, says)
        assert not out.exists(), name
        given = {k: [v for o, v in zip(options[::2], options[1::2], strict=True) if o == k]
                 for k in ("--nominal", "--bounds", "--params")}
        with pytest.raises(ParameterError, match=re.escape(says)):
            prior_box(ParameterSpace.t6(), nominal=given["--nominal"], bounds=given["--bounds"],
                      params=(given["--params"] or [None])[0])
    # the T6's D = 15: random search of 21 - (D + 4) = 2 evaluations, as before the assessment's reserve
    assert main(["identify", data[0], "--preset", "random", "--budget", "21", "--nominal", "rod_length=1.8",
                 "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "rod_length = 1.8 m in [1.62, 1.98] (default 1.74 in [1.566, 1.914])" in printed
    saved = IdentificationResult.load(out / "result.nc").config["prior_box"]["rod_length"]
    assert np.allclose([saved["nominal"], saved["lower"], saved["upper"]], [1.8, 1.62, 1.98])
    again = prior_box(ParameterSpace.t6(), params=str(out / "prior_box.json"))   # the written box reproduces it
    assert again["rod_length"] == ParameterSpace.t6().with_overrides(nominal={"rod_length": 1.8})["rod_length"]


def test_params_files_and_the_command_line_combine(tmp_path) -> None:
    t6 = ParameterSpace.t6()
    as_json = _params(tmp_path, "box.json", json.dumps({"rod_length": {"nominal": 2.0, "lower": 1.8, "upper": 2.2},
                                                        "damping": 150, "pretension": {"lower": 100, "upper": 200}}))
    as_toml = _params(tmp_path, "box.toml", "damping = 150\n[rod_length]\nnominal = 2.0\nlower = 1.8\nupper = 2.2\n"
                                            "[pretension]\nlower = 100\nupper = 200\n")
    a, b = prior_box(t6, params=as_json), prior_box(t6, params=as_toml)
    assert box_record(a) == box_record(b)
    assert (a["damping"].lower, a["damping"].upper) == pytest.approx((135.0, 165.0))    # ±10 % kept
    assert a["pretension"].nominal == 150.0                                             # inside: kept
    assert prior_box(t6, bounds=["pretension=160:200"])["pretension"].nominal == 180.0  # outside: the midpoint
    c = prior_box(t6, params=as_json, nominal=["rod_length=2.1"], bounds=["damping=100:300"])
    assert (c["rod_length"].nominal, c["rod_length"].lower, c["damping"].lower) == (2.1, 1.8, 100.0)
    assert prior_box(t6) is t6


def test_a_changed_box_runs_the_default_preset_without_its_latent_stage_with_one_note(tmp_path, capsys) -> None:
    assert main(["identify", "--toy", "push", "--nominal", "m=1.2", "--budget", "12", "--out", str(tmp_path),
                 "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert "m = 1.2 kg in [0.6, 1.8]" in captured.out
    notes = [line for line in captured.err.splitlines() if "no latent decoder" in line]
    assert len(notes) == 1 and notes[0].startswith("tensegrid identify: note: preset 'handoff-gn'")
    assert "Warning" not in captured.err and "warnings.warn" not in captured.err


def test_diagnose_validates_the_box_like_identify(tmp_path, data, capsys) -> None:
    out = tmp_path / "d"
    assert main(["diagnose", *data, "--bounds", "rod_length=2:1", "--out", str(out)]) == 2
    _error(capsys, "tensegrid diagnose: error: rod_length: lower bound 2.0 must be below upper bound 1.0")
    assert main(["diagnose", *data, "--bounds", "rod_length=1500:1900", "--out", str(out)]) == 2
    _error(capsys, "give --bounds rod_length=1.5:1.9")
    assert main(["diagnose", *data, "--budget", "0", "--out", str(out)]) == 2
    _error(capsys, "budget >= 2")
    assert main(["diagnose", *data, "--fit-rounds", "0", "--out", str(out)]) == 2
    _error(capsys, "--fit-rounds is the most least-squares runs per fit and must be at least 1, got 0")
    assert not out.exists()


# -------------------------------------------------------------------------------------------------- journals
def test_a_journal_of_another_problem_is_set_aside_unless_resume(tmp_path, capsys) -> None:
    out, run = tmp_path / "run", ["identify", *TOY, "--budget", "12"]       # 6 searched, 6 kept (D + 4)
    assert main([*run, "--bounds", "m=0.6:1.4", "--out", str(out)]) == 0        # the run with the wrong box
    capsys.readouterr()
    assert main([*run, "--resume", "--out", str(out)]) == 2
    _error(capsys, "was written by a different problem (differs in:", "space.lower", "drop --resume to set it aside")
    assert sorted(p.name for p in out.glob("journal*")) == ["journal.sqlite"]
    assert main([*run, "--out", str(out)]) == 0                                 # the corrected run
    err = capsys.readouterr().err
    assert f"note: journal {out / 'journal.sqlite'} was written by another problem" in err
    assert f"set aside as {out / 'journal.1.sqlite'}" in err
    assert _count(out / "journal.1.sqlite") == 6 and _count(out / "journal.sqlite") == 6
    assert IdentificationResult.load(out / "result.nc").config["prior_box"]["m"]["lower"] == 0.5
    assert main([*run, "--out", str(out)]) == 0                                 # the same problem: resumed
    assert f"note: resuming from 6 journalled evaluations ({out / 'journal.sqlite'})" in capsys.readouterr().err


def test_resume_needs_a_journal(tmp_path, capsys) -> None:
    out = tmp_path / "fresh"
    assert main(["identify", *TOY, "--budget", "12", "--resume", "--out", str(out)]) == 2
    _error(capsys, f"--resume: no journal at {out / 'journal.sqlite'} to resume")
    assert not out.exists()
    assert main(["identify", *TOY, "--budget", "12", "--journal", "none", "--resume", "--out", str(out)]) == 2
    _error(capsys, "--resume: no journal at None")
    assert main(["identify", *TOY, "--budget", "12", "--journal", str(tmp_path), "--out", str(out)]) == 2
    _error(capsys, "--journal", "is a folder")


def test_diagnose_sets_aside_a_foreign_journal_and_the_corrected_run_works(tmp_path, data, capsys) -> None:
    out = tmp_path / "d"
    run = ["diagnose", *data, "--budget", "3", "--candidates", "8", "--passes", "1", "--effects", "actuator_delay",
           "--horizon", "5", "--no-mismatch", "--no-progress", "--out", str(out)]
    assert main([*run, "--resume"]) == 2
    _error(capsys, "--resume: no journal at")
    assert not out.exists()
    out.mkdir()
    with Journal(out / "identify_pass0.sqlite", {"another": "problem"}) as foreign:
        foreign.append(Record(0, 0, (0.5,), (1.0,), 1.0, 0.1, "ok"))
    assert main([*run, "--resume"]) == 2
    _error(capsys, "written by a different problem")
    assert main(run) == 0
    err = capsys.readouterr().err
    assert f"set aside as {out / 'identify_pass0.1.sqlite'}" in err
    assert (out / "diagnosis.json").exists() and _count(out / "identify_pass0.1.sqlite") == 1
    assert _count(out / "identify_pass0.sqlite") == 3
