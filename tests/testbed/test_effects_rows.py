"""Which saved rows benchmarks/effects.py summarizes with ``--latest``: per protocol by default,
per data set and seed with ``--per-seed`` (a default's standing read from files in the order the
default changed); the contest line's parameters on which two contenders' fits differ most."""
from __future__ import annotations

from effects import latest_rows
from effects_table import _apart


def _row(seed: int, suspects: int, found: list[str]) -> dict:
    row = {"scenario": "drag+hysteresis", "seed": seed, "held_out": "testbed", "budget": 40, "flops_version": 2,
           "rounds": 4, "found": found}
    return {**row, "suspects": suspects} if suspects != 1 else row


def test_latest_keeps_one_row_per_protocol_and_per_seed_keeps_the_last() -> None:
    rows = [_row(1, 1, ["viscous_drag"]), _row(2, 1, []), _row(1, 1, []), _row(1, 3, ["cable_hysteresis"])]
    per_protocol = latest_rows(rows)
    assert [(r["seed"], r.get("suspects", 1), r["found"]) for r in per_protocol] == [
        (1, 1, []), (2, 1, []), (1, 3, ["cable_hysteresis"])]
    per_seed = latest_rows(rows, per_seed=True)
    assert [(r["seed"], r["found"]) for r in per_seed] == [(1, ["cable_hysteresis"]), (2, [])]


def test_apart_names_the_parameters_two_joint_fits_differ_on_most_relative_to_their_size() -> None:
    truth_fit = {"damping": 200.0, "targetVelocity": 1.41, "radius_mp": 0.0346, "rod_length": 1.7367}
    other_fit = {"damping": 205.0, "targetVelocity": 1.55, "radius_mp": 0.0316, "rod_length": 1.7367}
    assert _apart(truth_fit, other_fit, k=2) == "targetVelocity 1.41/1.55, radius_mp 0.0346/0.0316"
    assert _apart(truth_fit, truth_fit, k=1).startswith("damping 200/200")   # ties keep the fits' order
    assert _apart(truth_fit, other_fit, k=1, truth={"targetVelocity": 1.5}) == "targetVelocity 1.41/1.55 (θ* 1.5)"
