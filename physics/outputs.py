"""Output folders of the command line: checked before anything runs, created only once the inputs
are valid, removed again when a run fails before writing into them.

Every sub-command that takes ``--out DIR`` (identify, diagnose, plan, probe) calls
:func:`check_output_dir` first, which writes nothing and raises :class:`OutputError` (one line) for
an empty path, a path naming an existing file, a folder under a file and a folder that cannot be
written; then, after its inputs are validated, :func:`output_dir` creates the folder (an
``OSError`` there, such as a path under ``/proc``, is an :class:`OutputError` too) and, when the
run fails, removes the folders it created if they are still empty (:func:`make_output_dir` just
creates it, for a command that writes only once its work is done).
"""
from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from physics.errors import OutputError

__all__ = ["OutputError", "check_output_dir", "check_output_file", "make_output_dir", "output_dir"]


def _existing_ancestor(path: Path) -> Path:
    """The nearest of ``path`` and its parents that exists (the current folder for a relative path)."""
    for candidate in (path, *path.parents):
        if os.path.lexists(candidate):
            return candidate
    return Path(".")


def check_output_dir(path: str | os.PathLike[str], *, option: str = "--out") -> Path:
    """``path`` as a folder that can be created or written to; writes nothing. Raises OutputError."""
    text = os.fspath(path)
    if not text.strip():
        raise OutputError(f"{option} is empty; give a folder, e.g. {option} out/run.")
    if "\0" in text:
        raise OutputError(f"{option} {text!r} contains a NUL character; give a plain folder path.")
    folder = Path(text)
    if os.path.lexists(folder) and not folder.is_dir():
        raise OutputError(f"{option} {text} is an existing file, not a folder; give a folder path (new or existing).")
    base = _existing_ancestor(folder)
    if not base.is_dir():
        raise OutputError(f"{option} {text}: {base} is a file, so no folder can be made under it; give another path.")
    top = Path(os.path.realpath(base)).parts[1:2]
    if top in (("proc",), ("sys",)):
        raise OutputError(f"{option} {text} lies in /{top[0]}, a virtual file system of the kernel that holds no "
                          "files; give a folder on a disk.")
    if not os.access(base, os.W_OK | os.X_OK) or os.statvfs(base).f_flag & os.ST_RDONLY:
        raise OutputError(f"{option} {text}: {base} is not writable (permissions or a read-only file system); "
                          "give a folder you can write to.")
    return folder


def check_output_file(path: str | os.PathLike[str], *, option: str) -> Path:
    """``path`` as a file that can be written (its folder is checked as by :func:`check_output_dir`)."""
    text = os.fspath(path)
    if not text.strip():
        raise OutputError(f"{option} is empty; give a file path.")
    file = Path(text)
    if file.is_dir():
        raise OutputError(f"{option} {text} is a folder; give a file path in it.")
    check_output_dir(file.parent, option=f"{option} {text}: the folder")
    return file


def make_output_dir(path: str | os.PathLike[str], *, option: str = "--out") -> Path:
    """Create the folder ``path`` (checked first, parents too); an ``OSError`` is an OutputError."""
    folder = check_output_dir(path, option=option)
    _make(folder, option)
    return folder


def _make(folder: Path, option: str) -> list[Path]:
    """Create ``folder`` and its missing parents; the created ones, outermost first."""
    missing = [p for p in (folder, *folder.parents) if not os.path.lexists(p)][::-1]
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{option} {folder}: cannot create it ({exc.strerror or exc}); "
                          "give a folder you can write to.") from None
    return missing


@contextmanager
def output_dir(path: str | os.PathLike[str], *, option: str = "--out") -> Iterator[Path]:
    """Create the folder ``path`` (checked first) for the block; when the block raises, remove the
    folders this call created if nothing was written into them, so a failed run leaves no trace."""
    folder = check_output_dir(path, option=option)
    created = _make(folder, option)
    try:
        yield folder
    except BaseException:
        for made in reversed(created):
            try:
                made.rmdir()
            except OSError:         # not empty: the run wrote something worth keeping (a journal)
                break
        raise
