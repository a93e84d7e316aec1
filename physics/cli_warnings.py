"""Python warnings as the command line shows them: one plain line each, never a source line.

Left to Python, a warning raised while a sub-command runs (the project's own, such as the budget or
preset warnings of belief, or a library's, such as numpy's on an all-NaN slice) prints as
``FILE:LINE: Category: message`` followed by the line of source code that raised it, which tells a
user nothing they can act on. Inside :func:`plain_warnings` each distinct message prints once, as
``tensegrid COMMAND: note: message`` on stderr, the way the commands print their own notes; a
library's message says where in the code it arose, for a bug report, without the code itself. The
full record (category, file, line) goes to the ``tensegrid`` logger at DEBUG level, for whoever
configures logging to keep it. Which warnings show at all is still up to the warning filters.
"""
from __future__ import annotations

import logging
import os
import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

__all__ = ["plain_warnings", "warning_text", "PROJECT_PACKAGES"]

#: the packages whose warnings are written for the user: their message alone is the note
PROJECT_PACKAGES = ("physics", "embeddings", "belief", "criticism", "planners", "testbed")
_LOG = logging.getLogger("tensegrid")


def warning_text(message: Warning | str, category: type[Warning], filename: str, lineno: int) -> str:
    """The note for one warning: a project warning's message; a library's with the file and line it
    names (for numpy's, the project code that called numpy), from its package folder on."""
    text = " ".join(str(message).split())
    if category.__module__.split(".")[0] in PROJECT_PACKAGES:
        return text
    parts = os.path.normpath(filename).split(os.sep)
    inside = [k for k, part in enumerate(parts) if part in PROJECT_PACKAGES]
    where = "/".join(parts[inside[-1]:]) if inside else os.path.basename(filename)
    return f"{text} (raised at {where}, line {lineno}; the run goes on)"


@contextmanager
def plain_warnings(command: str, *, stream: TextIO | None = None) -> Iterator[None]:
    """Within the block, show each distinct warning once as ``tensegrid COMMAND: note: TEXT``
    (:func:`warning_text`) on ``stream`` (default stderr) and log its full record (module docstring).
    The warning filters and the previous display are restored on leaving the block."""
    shown: set[str] = set()

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: TextIO | None = None, line: str | None = None) -> None:
        _LOG.debug("%s:%s: %s: %s", filename, lineno, category.__name__, message)
        text = warning_text(message, category, filename, lineno)
        if text not in shown:
            shown.add(text)
            print(f"tensegrid {command}: note: {text}", file=stream or sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield
