"""Catalog search and residual phases on data with an undeclared effect (small versions of
benchmarks/effects.py, which prints the statistics over seeds)."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from belief.least_squares import LeastSquaresConfig
from criticism import CriticismError
from criticism.candidate import rescore as _rescore
from criticism.diagnose import split_masks
from criticism.residuals import phases, residual_dataset, residual_summary
from criticism.search import Candidate, Criticism, CriticismConfig, _contest, _order, _verdict, criticize
from physics import FlopController, HoldController, TrajectoryObjective, simulate
from physics.effects import (
    ActuatorDelay, EncoderOffset, EndCapRadius, GroundSlope, NonlinearStiffness, SensorBias, model_space,
)

pytestmark = pytest.mark.slow

#: A catalog subset, coarser fits and one short least-squares run per refinement (6 trial points, each
#: Jacobian k more; the default's further runs only lower the fit error: tests/belief/test_least_squares.py)
#: keep each criticism short.
SUBSET = [SensorBias(), EndCapRadius(), GroundSlope(), NonlinearStiffness(), ActuatorDelay()]
QUICK = CriticismConfig(grid=5, refine=5, joint=2, local=LeastSquaresConfig(evaluations=6))


def _flops(effects=(), values=None, headings=(0.0, 2.1), noise=0.0002, duration=1.2, nan=0):
    space = model_space(effects)
    theta = space.as_array({**space.as_dict(None), **(values or {})}, check_bounds=False)
    data = [simulate(theta, controller=FlopController(h), duration=duration, effects=effects, noise=noise, seed=k)
            for k, h in enumerate(headings)]
    if nan:
        data[0]["nodes"][40:40 + nan] = np.nan
    return data, theta


def test_phases_follow_commands_and_contacts():
    rest = simulate(controller=HoldController(), duration=0.5)
    assert set(phases(rest)) == {"rest"}
    flop, _ = _flops(headings=(0.0,), noise=0.0)
    label = phases(flop[0])
    t = flop[0]["time"].values
    assert label[t < 0.19].tolist() == ["rest"] * int((t < 0.19).sum())      # the flop starts at 0.2 s
    assert "actuating" in label[(t > 0.2) & (t < 1.0)] and "contact" in label


def test_residuals_skip_nan_samples_and_say_how_many():
    data, theta = _flops(headings=(0.0,), nan=5, duration=1.0)
    objective = TrajectoryObjective(data, horizon=1, loss="squared", n_workers=0)
    res = residual_dataset(objective, theta)
    assert np.isfinite(res["residual"].values).all()
    summary = residual_summary(res)
    assert summary["skipped"] == [5 + 1]              # 5 missing samples, and the one after them cannot be predicted
    assert sum(v["share"] for v in summary["phases"].values()) == pytest.approx(1.0)


def test_criticism_finds_a_sensor_bias_and_its_size():
    effects = [SensorBias()]
    data, theta = _flops(effects, {"sensor_bias_z": 0.02})
    objective = TrajectoryObjective(data, horizon=25, loss="squared", n_workers=0)
    fit, held = split_masks(objective.segments, [1])
    crit = criticize(objective, theta[:15], fit=fit, held=held, effects=SUBSET, config=QUICK, progress=False)
    assert crit.verdict == "found" and crit.found.name == "sensor_bias", crit.table()
    # a vertical bias and a larger cap radius both lift the resting robot: the data pin their sum
    lift = crit.found.values["sensor_bias_z"] + crit.found.theta[1] - theta[1]
    assert lift == pytest.approx(0.02, abs=0.004) and crit.found.values["sensor_bias_z"] > 0.01
    assert crit.found.explained > 0.5 and crit.ranking[0] is crit.found


def test_criticism_claims_nothing_on_data_the_model_explains():
    """With the default's refinements run to convergence: fitting further must not make a claim."""
    data, theta = _flops()
    objective = TrajectoryObjective(data, horizon=25, loss="squared", n_workers=0)
    fit, held = split_masks(objective.segments, [1])
    converged = replace(QUICK, local=CriticismConfig().local)
    crit = criticize(objective, theta, fit=fit, held=held, effects=SUBSET, config=converged, progress=False)
    assert crit.verdict == "unexplained" and crit.found is None, crit.table()


def test_criticism_refuses_bad_masks_and_norm_loss():
    data, theta = _flops(headings=(0.0,), duration=0.5)
    objective = TrajectoryObjective(data, horizon=5, loss="squared", n_workers=0)
    S = len(objective.segments)
    with pytest.raises(CriticismError, match="disjoint"):
        criticize(objective, theta, fit=np.ones(S, bool), held=np.ones(S, bool), effects=SUBSET)
    norm = TrajectoryObjective(data, horizon=5, loss="norm", n_workers=0)
    fit, held = split_masks(norm.segments, [])
    with pytest.raises(CriticismError, match="sum-of-squares"):
        criticize(norm, theta, fit=fit, held=held, effects=SUBSET)


def test_an_effect_outside_the_catalog_is_not_attributed_with_confidence():
    data, theta = _flops([EncoderOffset()], {"encoder_offset": 0.05})
    objective = TrajectoryObjective(data, horizon=25, loss="squared", n_workers=0)
    fit, held = split_masks(objective.segments, [1])
    crit = criticize(objective, theta[:15], fit=fit, held=held, effects=SUBSET, config=QUICK, progress=False)
    assert crit.verdict == "unexplained", crit.table()


def test_one_trajectory_alternates_its_windows_between_fit_and_held_out():
    effects = [ActuatorDelay()]
    data, theta = _flops(effects, {"actuator_delay": 0.08}, headings=(0.0,), duration=1.5)
    objective = TrajectoryObjective(data, horizon=25, loss="squared", windows=4, n_workers=0)
    fit, held = split_masks(objective.segments, [])
    assert fit.tolist() == [True, False, True, False]
    crit = criticize(objective, theta[:15], fit=fit, held=held, effects=[SensorBias(), ActuatorDelay()],
                     config=replace(QUICK, refine=3), progress=False)
    assert crit.verdict == "found" and crit.found.name == "actuator_delay", crit.table()
    assert crit.found.explained > 0.5 and crit.found.values["actuator_delay"] == pytest.approx(0.08, abs=0.02)


def _omission_costs(data, theta, effects, held) -> dict[str, float]:
    """Held-out error at the true θ of the model that lacks each effect (the larger effect costs more)."""
    objective = TrajectoryObjective(data, horizon=25, loss="squared", effects=effects, n_workers=0)
    costs = {}
    for k, effect in enumerate(effects):
        without = theta.copy()
        without[15 + k] = effect.parameters()[0].nominal     # one parameter each here: its off value
        costs[effect.name] = float(objective.evaluate_batch(without[None]).parts[0][held].sum())
    return costs


def test_a_mix_of_two_effects_finds_the_larger_first_and_the_other_next():
    effects = [ActuatorDelay(), GroundSlope()]
    data, theta = _flops(effects, {"actuator_delay": 0.08, "slope_x": 0.08})
    objective = TrajectoryObjective(data, horizon=25, loss="squared", n_workers=0)
    fit, held = split_masks(objective.segments, [1])
    costs = _omission_costs(data, theta, effects, held)
    larger, smaller = sorted(costs, key=costs.get, reverse=True)
    crit = criticize(objective, theta[:15], fit=fit, held=held, effects=effects, config=QUICK, progress=False)
    assert crit.verdict == "found" and crit.found.name == larger, (costs, crit.table())
    first = next(e for e in effects if e.name == larger)
    model = objective.with_effects([first])
    nxt = criticize(model, np.asarray(crit.found.theta, float), fit=fit, held=held, effects=[e for e in effects if e is not first], config=QUICK,
                    progress=False)
    assert nxt.verdict == "found" and nxt.found.name == smaller, nxt.table()


def test_effects_the_evidence_cannot_tell_apart_are_named_and_ranked_by_evidence():
    def c(name, evidence, explained):
        return Candidate(name, "effect", {name: 1.0}, 1.0, 1.0, explained, evidence, stage="joint")

    config = CriticismConfig(min_replication=None)      # ranking rules only: no objective to replicate on
    ranking = _order([c("caps", 83.9, 0.84), c("bias", 85.1, 0.80), c("drag", 20.0, 0.9), c("slope", 86.0, 0.2)], config)
    assert [r.name for r in ranking] == ["bias", "caps", "slope", "drag"]    # slope is close but would not be found
    crit = _verdict(None, Criticism(np.zeros(15), 1.0, 1.0, 10, 10, ranking, ranking[0], "unexplained", None), None,
                    None, config)
    assert crit.found.name == "bias" and crit.alternatives == ["caps", "slope"]
    apart = _order([c("caps", 83.9, 0.84), c("bias", 95.0, 0.80)], config)
    assert [r.name for r in apart] == ["bias", "caps"]


def test_contenders_are_scored_on_common_effective_counts():
    """Two effects that both pass: their evidence difference becomes a likelihood ratio on one K."""
    base = (0.454, 0.211)
    config = CriticismConfig()
    bias = _rescore(Candidate("bias", "effect", {"b": 0.018}, 0.0192, 0.0157, 0, 0, n_fit=40.3, n_held=22.5,
                              stage="joint", theta=(1.0,)), base)
    caps = _rescore(Candidate("caps", "effect", {"c": 0.017}, 0.0239, 0.0140, 0, 0, n_fit=39.8, n_held=30.7,
                              stage="joint", theta=(1.0,)), base)
    drag = _rescore(Candidate("drag", "effect", {"d": 0.0}, 0.45, 0.21, 0, 0, n_fit=8.0, n_held=4.6,
                              stage="joint", theta=(1.0,)), base)
    assert caps.evidence > bias.evidence + config.tie          # each on its own K: the larger K_H decides
    ranking, contest = _contest([caps, bias, drag], base, config)
    assert contest["effects"] == ["caps", "bias"] and ranking[2] is drag     # drag does not pass: untouched
    k_fit, k_held = contest["n_fit"], contest["n_held"]
    assert (k_fit, k_held) == pytest.approx((40.05, 26.6))
    scored = {r.name: r for r in ranking}
    ratio = k_fit * math.log(0.0239 / 0.0192) + k_held * math.log(0.0140 / 0.0157)
    assert scored["bias"].evidence - scored["caps"].evidence == pytest.approx(ratio)
    assert ratio > 0                                           # on common K the better total fit wins
    alone, none = _contest([caps, drag], base, config)
    assert none is None and alone == [caps, drag]
