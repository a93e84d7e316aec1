"""The parameters criticism's re-tuning leaves at a bound of the box (model inadequacy):
``retuned_at_bounds``, ``DiagnoseConfig.bound_tolerance`` and the diagnosis report's block."""
from __future__ import annotations

import json

import numpy as np
import pytest

from belief import AtBound, Belief, SobolCandidates, at_bounds
from criticism import (
    Candidate, Criticism, CriticismError, DiagnoseConfig, Diagnosis, Pass, diagnosis_record, diagnosis_text,
    retuned_at_bounds,
)
from embeddings import Identity
from physics import ParameterSpace

T6 = ParameterSpace.t6()


def _theta(**unit: float) -> np.ndarray:
    """θ of the T6 box at the box centre, with the named parameters at the given unit-box values."""
    u = np.full(T6.dim, 0.5)
    for name, value in unit.items():
        u[T6.index(name)] = value
    return T6.lower + u * (T6.upper - T6.lower)


def _belief(at: list[AtBound]) -> Belief:
    """A flat Belief over 64 Sobol cells of the T6 box whose identification pinned ``at``."""
    dec = Identity(T6)
    grid = SobolCandidates.for_decoder(dec, n=64, seed=0)
    P = grid.to_dataarray(np.full(grid.size, 1.0 / grid.size))
    return Belief.from_posterior(P, dec, grid, attrs={"at_bounds": [a.as_dict() for a in at], "bound_tolerance": 0.01})


def test_retuned_at_bounds_lists_what_the_re_tuning_moved_or_the_identification_pinned() -> None:
    start = _theta(density=1.0, rod_length=1.0, damping=0.4)
    retuned = _theta(density=1.0, rod_length=1.0, damping=0.0, stiffnessActive=1.0)
    b = _belief(list(at_bounds(T6, start)[1:]))             # the identification pinned rod_length, not density
    names = [(a.name, a.side, a.source) for a in retuned_at_bounds(T6, start, retuned, b)]
    assert names == [("rod_length", "upper", "re-tuning"), ("stiffnessActive", "upper", "re-tuning"),
                     ("damping", "lower", "re-tuning")]
    assert [a.name for a in retuned_at_bounds(T6, start, retuned, None)] == ["stiffnessActive", "damping"]


def test_bound_tolerance_outside_half_the_box_is_refused() -> None:
    with pytest.raises(CriticismError, match="bound_tolerance"):
        DiagnoseConfig(bound_tolerance=-0.1)
    with pytest.raises(CriticismError, match="bound_tolerance"):
        DiagnoseConfig(bound_tolerance=0.5)


def test_no_suspect_for_the_second_look_is_refused() -> None:
    with pytest.raises(CriticismError, match="suspects >= 1"):
        DiagnoseConfig(suspects=0)


def _diagnosis(at: tuple[AtBound, ...]) -> Diagnosis:
    floor = Candidate("re-tuned model", "floor", {"damping": 180.0}, 1.0, 2.0, 0.1, 3.0)
    crit = Criticism(_theta(), 1.0, 2.0, 10.0, 10.0, [], floor, "unexplained", None)
    step = Pass((), T6.names, _theta(), crit, {"t1": 2.0}, at_bounds=at)
    return Diagnosis([step], (), [1], _belief([]), {"bound_tolerance": 0.01})


def test_diagnose_report_lists_the_parameters_at_bounds_after_the_re_tuning() -> None:
    at = at_bounds(T6, _theta(stiffnessActive=1.0, damping=0.0), source="re-tuning")
    text = diagnosis_text(_diagnosis(at))
    assert "Model inadequacy: 2 parameters sit at a bound of the prior box after the re-tuning" in text
    assert "stiffnessActive at upper bound 880 N/m (+10 % of nominal)" in text
    assert "damping at lower bound 180 N*s/m (-10 % of nominal)" in text
    record = json.loads(json.dumps(diagnosis_record(_diagnosis(at)), default=float))
    assert [(r["name"], r["side"]) for r in record["passes"][0]["at_bounds"]] == [("stiffnessActive", "upper"),
                                                                                ("damping", "lower")]
    assert "Model inadequacy" not in diagnosis_text(_diagnosis(()))
