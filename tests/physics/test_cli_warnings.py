"""Python warnings in the command line's output: one plain note each, never ``FILE:LINE: Category:``
with the source line under it (physics.cli_warnings, around every sub-command in physics.cli.main)."""
from __future__ import annotations

import warnings

import numpy as np

from physics.cli_warnings import plain_warnings, warning_text


class ProjectNote(UserWarning):
    """A warning of the project's own, as belief's budget and preset warnings are."""


ProjectNote.__module__ = "belief.errors"


def _raise_some() -> None:
    for _ in range(3):
        warnings.warn("a budget of 6 gives the GP too few evaluations", ProjectNote, stacklevel=1)
    np.nanmax(np.full((2, 3), np.nan), axis=1)                   # numpy's RuntimeWarning: All-NaN slice


def test_each_warning_is_one_plain_note(capsys) -> None:
    shown = warnings.showwarning
    with plain_warnings("diagnose"):
        _raise_some()
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert lines[0] == "tensegrid diagnose: note: a budget of 6 gives the GP too few evaluations"
    assert lines[1].startswith("tensegrid diagnose: note: All-NaN slice encountered (raised at physics/"
                               "test_cli_warnings.py, line ")
    assert len(lines) == 2                                       # once each, no source line under it
    assert "Warning:" not in err and "np.nanmax" not in err and "warnings.warn" not in err
    assert warnings.showwarning is shown                         # the display is restored


def test_a_library_warning_names_where_not_what_code() -> None:
    text = warning_text("All-NaN slice\n encountered", RuntimeWarning, "/site/x/criticism/residuals.py", 49)
    assert text == "All-NaN slice encountered (raised at criticism/residuals.py, line 49; the run goes on)"
    assert warning_text("plain", ProjectNote, "/anywhere/belief/assess.py", 3) == "plain"
