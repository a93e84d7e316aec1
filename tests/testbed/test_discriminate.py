"""benchmarks/discriminate.py: a candidate flop that repeats a recorded one is not "one more flop"."""
from __future__ import annotations

from discriminate import _new_motions

from criticism.discrimination import Separation


def test_candidates_with_a_recorded_flops_separation_are_that_flop_again_and_left_out() -> None:
    seps = [Separation("recorded t2", 0.0064, True), Separation("flop 60°", 0.0064),
            Separation("flop 180°", 0.0062), Separation("recorded t0", 0.0056, True), Separation("flop 300°", 0.0042)]
    assert [s.label for s in _new_motions(seps)] == ["flop 180°", "flop 300°"]
