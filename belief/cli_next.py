"""``tensegrid identify``'s last step: what to record next (belief.next_recording), printed, appended to
summary.txt and written to ``next_recording.json``, which ``tensegrid probe --next`` runs.

The design needs the data objective's workers, so it runs before they close; what it cannot do
(no likelihood σ², a simulation that diverges) is one note, never a failed identification.
"""
from __future__ import annotations

import argparse
import json
import os
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from belief.next_recording import RecordingSuggestion
    from belief.result import IdentificationResult
    from physics.measurements import MeasurementPrior
    from physics.objective import Objective

__all__ = ["add_next_options", "design_next", "write_next", "NEXT_FILE"]

#: the file ``tensegrid probe --next`` reads
NEXT_FILE = "next_recording.json"


def add_next_options(g: argparse._ArgumentGroup) -> None:
    """``--no-next``."""
    g.add_argument("--no-next", action="store_true",
                   help="skip 'what to record next' (candidate flops simulated at the best θ and scored by the "
                        "information they would bring; belief.next_recording)")


def design_next(result: IdentificationResult, objective: Objective, known: MeasurementPrior, *,
                say: Callable[[str], None]) -> RecordingSuggestion | None:
    """belief.next_recording.next_recording for the run, with one ``say`` note up front (what it
    scores, about how long) and instead of a suggestion when it cannot be made."""
    from belief.errors import BeliefError
    from belief.next_recording import DEFAULT_DESIGN, expected_seconds, next_recording
    from physics.errors import TensegridError

    seconds = expected_seconds(result, objective)
    say(f"what to record next: scoring {DEFAULT_DESIGN.candidates} candidate flops"
        + ("" if seconds is None else f" (about {seconds:.0f} s; --no-next skips it)"))
    try:
        return next_recording(result, objective, known=known)
    except (TensegridError, BeliefError) as exc:
        say(f"what to record next: skipped ({exc})")
        return None


def write_next(out: str, suggestion: RecordingSuggestion) -> list[str]:
    """``OUT/next_recording.json``, the section appended to ``OUT/summary.txt``; returns its lines."""
    lines = suggestion.lines() + [f"  run it on a simulated robot: tensegrid probe {os.path.join(out, 'result.nc')} "
                                  f"--next {os.path.join(out, NEXT_FILE)} --truth THETA.json --out DIR"]
    with open(os.path.join(out, NEXT_FILE), "w") as fh:
        json.dump(suggestion.as_dict(), fh, indent=1)
    with open(os.path.join(out, "summary.txt"), "a") as fh:
        fh.write("\n".join(lines) + "\n")
    return lines
