"""Parameters pinned at a bound of the box after fitting: detection, the "at bound" verdict rule, the Belief's
summary and file, and identify on data the model cannot fit (criticism's re-tuning:
tests/criticism/test_diagnose.py)."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st

from belief import AT_BOUND_TOLERANCE, AtBound, Belief, SobolCandidates, VerdictConfig, at_bounds, identify
from belief.bounds import entries_from_records, inadequacy_text
from belief.errors import BeliefError
from belief.result import IdentificationResult
from belief.verdicts import pinned
from embeddings import Identity
from physics import FlopController, ParameterSpace, TrajectoryObjective, simulate

T6 = ParameterSpace.t6()


def _theta(**unit: float) -> np.ndarray:
    """θ of the T6 box at the box centre, with the named parameters at the given unit-box values."""
    u = np.full(T6.dim, 0.5)
    for name, value in unit.items():
        u[T6.index(name)] = value
    return T6.lower + u * (T6.upper - T6.lower)


# ---------------------------------------------------------------------------------------- detection
@settings(max_examples=60, deadline=None)
@given(u=st.lists(st.floats(0.0, 1.0), min_size=15, max_size=15), tol=st.floats(0.0, 0.2))
def test_a_theta_strictly_inside_is_never_reported(u, tol) -> None:
    margin = tol + 1e-6
    inside = margin + np.asarray(u) * (1.0 - 2.0 * margin)
    assert at_bounds(T6, T6.lower + inside * (T6.upper - T6.lower), tolerance=tol) == ()


@settings(max_examples=40, deadline=None)
@given(j=st.integers(0, 14), k=st.integers(0, 14))
def test_exactly_at_a_bound_is_reported_with_its_side_and_value(j, k) -> None:
    theta = _theta()
    theta[j], theta[k] = T6.lower[j], T6.upper[k]
    found = {a.name: a for a in at_bounds(T6, theta)}
    assert set(found) == {T6.names[j], T6.names[k]}
    assert found[T6.names[k]].side == "upper" and found[T6.names[k]].bound == T6.upper[k]
    if j != k:
        assert found[T6.names[j]].side == "lower" and found[T6.names[j]].bound == T6.lower[j]


def test_the_tolerance_is_a_fraction_of_the_box_width() -> None:
    assert AT_BOUND_TOLERANCE == 0.01
    near = _theta(stiffnessActive=0.995, damping=0.009, density=0.011, radius=0.985)
    assert [(a.name, a.side) for a in at_bounds(T6, near)] == [("stiffnessActive", "upper"), ("damping", "lower")]
    assert {a.name for a in at_bounds(T6, near, tolerance=0.02)} == {"stiffnessActive", "damping", "density", "radius"}
    assert at_bounds(T6, near, tolerance=0.0) == ()
    outside = _theta(rod_length=1.3)                      # beyond the box: at the bound it passed
    assert [(a.name, a.side, a.value) for a in at_bounds(T6, outside)] == [("rod_length", "upper", outside[4])]


def test_entries_describe_the_bound_and_its_direction() -> None:
    theta = _theta(stiffnessActive=1.0, damping=0.0)
    stiff, damp = at_bounds(T6, theta, source="re-tuning")
    assert stiff.describe() == "stiffnessActive at upper bound 880 N/m (+10 % of nominal)"
    assert damp.describe() == "damping at lower bound 180 N*s/m (-10 % of nominal)"
    assert "pinned at the upper bound 880 by the re-tuning" in stiff.reason() and "not an estimate" in stiff.reason()
    assert AtBound.from_dict(json.loads(json.dumps(stiff.as_dict()))) == stiff
    text = inadequacy_text((stiff, damp), after="the re-tuning")
    assert text.startswith("Model inadequacy: 2 parameters sit at a bound of the prior box after the re-tuning")
    assert "these values are not estimates" in text and inadequacy_text(()) == ""


def test_start_keeps_only_the_parameters_the_fit_moved_to_a_bound() -> None:
    start = _theta(density=1.0, radius=0.0, damping=0.3)
    fitted = _theta(density=1.0, radius=1.0, damping=0.0)
    assert [(a.name, a.side) for a in at_bounds(T6, fitted, start=start)] == [("radius", "upper"), ("damping", "lower")]


def test_bad_input_is_refused_with_the_fix() -> None:
    with pytest.raises(BeliefError, match="tolerance must be a fraction of the box width"):
        at_bounds(T6, _theta(), tolerance=0.5)
    with pytest.raises(BeliefError, match=r"theta must be finite with shape \(15,\)"):
        at_bounds(T6, _theta()[:3])
    with pytest.raises(BeliefError, match="start must be finite"):
        at_bounds(T6, _theta(), start=np.zeros(2))
    with pytest.raises(BeliefError, match="side must be one of"):
        AtBound("x", "m", "middle", 1.0, 1.0, 1.0)
    with pytest.raises(BeliefError, match="not an at-bound record"):
        AtBound.from_dict({"name": "x"})
    with pytest.raises(BeliefError, match="not parameters"):
        entries_from_records([AtBound("ghost", "m", "upper", 1.0, 1.0, 1.0).as_dict()], T6.names)
    with pytest.raises(BeliefError, match="bound_tolerance"):
        VerdictConfig(bound_tolerance=0.7)


# --------------------------------------------------------------------------- "at bound" and Belief
def _marginals(std: list[float]) -> xr.Dataset:
    names = ["a", "b", "c"]
    return xr.Dataset({"std": ("parameter", np.asarray(std)), "prior_std": ("parameter", np.ones(3))},
                      coords={"parameter": names})


def test_rule_6_keeps_only_parameters_the_data_narrow() -> None:
    found = tuple(AtBound(n, "m", "upper", 1.0, 1.0, 0.5) for n in ("a", "b", "c"))
    assert [a.name for a in pinned(_marginals([0.1, 0.79, 0.9]), found, weak_ratio=0.8)] == ["a", "b"]
    wide = pinned(_marginals([0.1, 0.1, 0.1]), found, weak_ratio=0.8, local_ratio=[0.2, 1.5, 0.0])
    assert [a.name for a in wide] == ["a", "c"]             # local width: the local fit sees no information on b


def _belief(at: list[AtBound]) -> Belief:
    space = ParameterSpace.t6()
    dec = Identity(space)
    grid = SobolCandidates.for_decoder(dec, n=64, seed=0)
    P = grid.to_dataarray(np.full(grid.size, 1.0 / grid.size))
    return Belief.from_posterior(P, dec, grid, attrs={"at_bounds": [a.as_dict() for a in at], "bound_tolerance": 0.01})


def test_belief_summary_marks_pinned_rows_and_states_the_inadequacy(tmp_path) -> None:
    entry = at_bounds(T6, _theta(rod_length=1.0), source="local fit")
    b = _belief(list(entry))
    text = b.summary()
    row = next(line for line in text.splitlines() if line.startswith("rod_length "))
    assert row.endswith("(at upper bound)")
    assert "Model inadequacy: 1 parameter sits at a bound" in text and "rod_length at upper bound 1.914 m" in text
    assert "at upper bound" not in next(line for line in text.splitlines() if line.startswith("density "))
    assert b.marginals()["at_bound"].sel(parameter="rod_length").item() == "upper"
    b.save(tmp_path / "b.nc")
    assert Belief.load(tmp_path / "b.nc").at_bounds == entry
    assert "Model inadequacy" not in _belief([]).summary() and _belief([]).at_bounds == ()


def test_belief_refuses_corrupt_at_bound_records() -> None:
    with pytest.raises(BeliefError, match="not parameters"):
        _belief([AtBound("ghost", "m", "upper", 1.0, 1.0, 1.0)])


# ------------------------------------------------------------- identify on data the model cannot fit
def _identify_rod(rod_length: float) -> IdentificationResult:
    """One 1.2 s flop of a robot whose rods are ``rod_length`` long; the other parameters nominal.
    Full-space BO, 20 evaluations (about 10 s on one core)."""
    theta = T6.replace(T6.nominal, rod_length=rod_length)
    data = simulate(T6.as_array(theta, check_bounds=False), controller=FlopController(heading=0.0), duration=1.2)
    decoder = Identity(T6)
    grid = SobolCandidates.for_decoder(decoder, n=1024, seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                    # 20 evaluations in 15-D: the budget warning
        return identify(TrajectoryObjective(data, loss="squared", n_workers=0), decoder, grid, budget=20, seed=0,
                        progress=False)


@pytest.mark.slow
@pytest.mark.parametrize("rod_length, side, percent", [(2.0, "upper", "+10"), (1.5, "lower", "-10")])
def test_identify_reports_a_parameter_the_data_push_out_of_the_box(rod_length, side, percent, tmp_path) -> None:
    """rod_length outside the ±10 % box (1.566-1.914 m): the fit ends on the bound it cannot pass,
    the summary says so and the verdict is withdrawn."""
    result = _identify_rod(rod_length)
    rod = [a for a in result.at_bounds if a.name == "rod_length"]
    assert len(rod) == 1 and rod[0].side == side
    assert rod[0].bound == (T6.upper if side == "upper" else T6.lower)[T6.index("rod_length")]
    text = result.summary()
    assert f"rod_length at {side} bound {rod[0].bound:.4g} m ({percent} % of nominal)" in text
    row = next(line for line in text.splitlines() if line.startswith("rod_length "))
    assert row.endswith(f"not identified (at {side} bound)")
    assert "pinned at the" in result.belief.verdicts["rod_length"][1]
    result.save(tmp_path / "r.nc")
    assert IdentificationResult.load(tmp_path / "r.nc").at_bounds == result.at_bounds


@pytest.mark.slow
def test_identify_reports_nothing_when_the_truth_is_inside_the_box() -> None:
    """The control: rod_length 1.70 m inside the box. The local step leaves parameters the data do
    not see on the box's edge (density and motor_inertia with this seed); the "at bound" rule does not list them."""
    result = _identify_rod(1.70)
    assert result.at_bounds == () and "Model inadequacy" not in result.summary()
    local = np.asarray(result.belief.attrs["local_fit"]["theta"])
    assert at_bounds(T6, local) != ()                        # the geometric test alone would have reported them


@pytest.mark.slow
def test_cli_prints_and_writes_the_inadequacy_block(tmp_path, capsys) -> None:
    """``tensegrid identify`` on the 2.0 m-rod flop: refused before any simulation, as the markers show
    rods outside the box; with --skip-checks the printed summary and summary.txt say it."""
    import argparse

    from belief.cli import register_identify
    from physics import save_trajectory

    theta = T6.replace(T6.nominal, rod_length=2.0)
    data = simulate(T6.as_array(theta, check_bounds=False), controller=FlopController(heading=0.0), duration=1.2)
    path = save_trajectory(data, tmp_path / "long_rods.nc")
    parser = argparse.ArgumentParser(prog="tensegrid")
    register_identify(parser.add_subparsers(dest="command", required=True))
    # BO's 20 evaluations of _identify_rod: the preset keeps the T6's D + 4 = 19 more for the assessment
    argv = ["identify", str(path), "--preset", "bo", "--budget", "39", "--candidates", "1024",
            "--out", str(tmp_path / "out"), "--no-progress", "--no-next"]
    refused = parser.parse_args(argv)
    assert refused.func(refused) == 2 and "--bounds rod_length=" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    args = parser.parse_args([*argv, "--skip-checks"])
    assert args.func(args) == 0
    printed, written = capsys.readouterr().out, (tmp_path / "out" / "summary.txt").read_text()
    for text in (printed, written):
        assert "Model inadequacy:" in text
        assert "rod_length at upper bound 1.914 m (+10 % of nominal)" in text
    marginals = (tmp_path / "out" / "marginals.csv").read_text().splitlines()
    assert "at_bound" in marginals[0] and any(r.startswith("rod_length,") and "upper" in r for r in marginals)
