"""The "structure" verdict rule (criticism.revisit): an effect found on the second look is sized
with the components the data let in beside it; when its size alone lies outside that interval the
size hangs on the structure, and the re-identified Belief calls it not identified."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from belief.belief import Belief
from belief.grid import Grid
from belief.verdicts import rule_of
from criticism.diagnose import Pass, _record_after
from criticism.report import estimate_verdict
from criticism.revisit import Revisit
from embeddings import Identity
from physics.effects import TensionLimitedActuation
from physics.parameters import Parameter, ParameterSpace

SPACE = ParameterSpace((Parameter("rate", "1", 1.0, 0.5, 2.0),
                        Parameter("hysteresis", "1", 0.3, 0.0, 1.0, minimum=-1.0)))


def _belief(centre: float, verdict: str = "identified") -> Belief:
    """A Belief narrow around hysteresis = centre (std 0.03)."""
    dec = Identity(SPACE)
    grid = Grid.for_decoder(dec, points_per_dim=41)
    h = grid.points[:, 1]
    p = np.exp(-0.5 * ((h - centre) / 0.03) ** 2)
    P = grid.to_dataarray(p / p.sum(), name="P")
    return Belief.from_posterior(P, dec, grid, verdicts=["weakly identified", verdict],
                                 reasons=["narrowing: r", "narrowing: h"])


def _revisit(alone: float) -> Revisit:
    return Revisit("cable_hysteresis", ("tension_limited_actuator",),
                   SimpleNamespace(effects=(TensionLimitedActuation(),)), None, True, {"hysteresis": alone})


def test_a_size_alone_inside_the_interval_keeps_its_verdict() -> None:
    b = _belief(0.55)
    lo, hi = b.interval()[1]
    assert lo < 0.55 < hi
    assert _revisit(0.5 * (lo + hi)).check_sizes(b) is b


def test_a_size_alone_outside_the_interval_is_not_identified() -> None:
    b = _belief(0.55)
    checked = _revisit(0.21).check_sizes(b)
    verdict, reason = checked.verdicts["hysteresis"]
    assert verdict == "not identified" and checked.rules[1] == "structure"
    assert "0.21 with cable_hysteresis alone" in reason and "tension_limited_actuator" in reason
    assert checked.verdicts["rate"] == b.verdicts["rate"]
    assert _revisit(0.21).check_sizes(_belief(0.55, "not identified")).rules[1] == "narrowing"


def test_the_loop_checks_sizes_only_for_an_effect_the_second_look_found() -> None:
    """diagnose records the re-identification's Belief through the check when the pass's effect
    came from the second look, and as it is when criticism found it itself."""
    objective = SimpleNamespace(space=SPACE, segments=("t0/w0",), evaluate_parts=lambda theta: np.array([1.0]))
    ident = SimpleNamespace(best_theta=np.array([1.0, 0.55]), belief=_belief(0.55))
    for found, rule in ((None, "structure"), (object(), "narrowing")):
        step = Pass((), ("rate",), np.array([1.0]), SimpleNamespace(found=found), {"t0": 2.0}, looks=(_revisit(0.21),))
        _record_after(step, "cable_hysteresis", objective, ident, np.array([True]))
        assert step.belief_after.rules[1] == rule and step.held_after == {"t0": 1.0}


def test_the_report_gives_the_structure_rule_its_words() -> None:
    """A verdict the structure rule decided is printed with its reason in plain words (P cannot show
    it), the rule's name left to the API; others only with their verdict and bound."""
    checked = _revisit(0.21).check_sizes(_belief(0.55))
    verdict, reason = checked.verdicts["hysteresis"]
    text = estimate_verdict({"verdict": verdict, "reason": reason, "at_bound": ""})
    assert rule_of(reason) == "structure" and "structure" not in text
    assert text.startswith("not identified (0.21 with cable_hysteresis alone")
    assert estimate_verdict({"verdict": "identified", "reason": "narrowing: ok", "at_bound": "upper"}) == \
        "identified (at upper bound)"
