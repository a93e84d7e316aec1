"""Replication across trajectories (criticism.replication): an effect every trajectory carries
carries over from one to another; one whose size follows each trajectory does not, and is not found."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from belief.least_squares import LeastSquaresConfig
from criticism import search
from criticism.diagnose import split_masks
from criticism.replication import fit_groups, refit_replication_gains, replication_gains
from criticism.search import CriticismConfig, criticize
from physics import FlopController, TrajectoryObjective, simulate
from physics.effects import ActuatorDelay, model_space

#: The evidence bar off: these tests are about replication, on data with little of the model's own freedom in them;
#: one least-squares run per refinement keeps them short.
LENIENT = CriticismConfig(grid=5, refine=3, joint=1, min_evidence=0.0, local=LeastSquaresConfig(rounds=1))
#: The refit check re-tunes all the model's parameters twice per fit flop: short runs keep it affordable.
SHORT_FITS = replace(LENIENT, local=LeastSquaresConfig(evaluations=3, rounds=1))


def test_groups_are_the_fit_trajectories_and_one_trajectory_is_no_replication():
    segments = ["t0/w0", "t0/w1", "t1/w0", "t1/w1", "t2/w0"]
    fit = np.array([True, True, True, True, False])
    groups = fit_groups(segments, fit)
    assert list(groups) == ["t0", "t1"] and groups["t1"].tolist() == [False, False, True, True, False]
    assert fit_groups(["t0/w0", "t0/w1", "t0/w2"], np.array([True, False, True])) == {}
    assert fit_groups(["t0/w0", "t1/w0"], np.array([True, False])) == {}


def _delayed_flops(delays: list[float], duration: float = 1.2) -> tuple[list, np.ndarray]:
    """One flop per delay [s] (headings 0, 2.1, 4.2 rad), ``duration`` [s], 0.2 mm noise; the model's true θ (15,)."""
    effect = ActuatorDelay()
    space = model_space([effect])
    data = []
    for k, delay in enumerate(delays):
        theta = space.as_array({**space.as_dict(None), "actuator_delay": delay}, check_bounds=False)
        data.append(simulate(theta, controller=FlopController(2.1 * k), duration=duration, effects=[effect],
                             noise=0.0002, seed=k))
    return data, theta[:15]


@pytest.mark.slow
def test_an_effect_every_trajectory_carries_replicates_and_one_that_varies_does_not():
    data, theta = _delayed_flops([0.08, 0.08, 0.0])
    objective = TrajectoryObjective(data[:2], horizon=25, loss="squared", n_workers=0)
    fit = np.ones(len(objective.segments), bool)
    gains = replication_gains(objective, theta, ActuatorDelay(), fit, grid=5, refine=3)
    assert set(gains) == {"t0", "t1"} and min(gains.values()) > 0.5, gains
    varying = TrajectoryObjective([data[0], data[2]], horizon=25, loss="squared", n_workers=0)
    gains = replication_gains(varying, theta, ActuatorDelay(), fit, grid=5, refine=3)
    assert min(gains.values()) < 0 and math.isfinite(min(gains.values())), gains


@pytest.mark.slow
def test_an_effect_that_does_not_replicate_is_not_found_though_it_helps_the_held_out_flop():
    """The delay passes both bars (without the check it would be found: :func:`search._verdict`
    finds a top effect that passes and replicates) and is not found, because it does not replicate."""
    data, theta = _delayed_flops([0.14, 0.0, 0.14])      # the held-out flop (last) is delayed like the first
    objective = TrajectoryObjective(data, horizon=25, loss="squared", n_workers=0)
    fit, held = split_masks(objective.segments, [2])
    held_only = replace(LENIENT, refit_replication=False)     # the refit check has its own tests below
    crit = criticize(objective, theta, fit=fit, held=held, effects=[ActuatorDelay()], config=held_only, progress=False)
    top = crit.ranking[0]
    assert top.name == "actuator_delay" and search._passes(top, held_only), crit.table()
    assert crit.verdict == "unexplained" and crit.found is None, crit.table()
    assert crit.replication is not None and not crit.replication["replicated"]
    assert "does not replicate" in crit.table()


@pytest.mark.slow
def test_refitted_with_the_model_an_effect_whose_size_varies_between_flops_does_not_replicate():
    data, theta = _delayed_flops([0.08, 0.0], duration=0.8)      # one that carries (test below) replicates
    varying = TrajectoryObjective(data, horizon=25, loss="squared", n_workers=0)
    fit = np.ones(len(varying.segments), bool)
    gains = refit_replication_gains(varying, theta, np.r_[theta, 0.08], ActuatorDelay(), fit, SHORT_FITS.local)
    assert set(gains) == {"t0", "t1"} and math.isfinite(min(gains.values())), gains
    assert gains["t1"] < 0, gains            # fitted on the delayed flop, it misfits the one without


@pytest.mark.slow
def test_an_effect_that_fails_with_the_model_held_is_found_when_it_replicates_refitted(monkeypatch):
    data, theta = _delayed_flops([0.08, 0.08, 0.08], duration=0.8)
    objective = TrajectoryObjective(data, horizon=25, loss="squared", n_workers=0)
    fit, held = split_masks(objective.segments, [2])
    monkeypatch.setattr(search, "replication_gains", lambda *a, **k: {"t0": -0.5, "t1": 0.2})   # θ̃ held: fails
    crit = criticize(objective, theta, fit=fit, held=held, effects=[ActuatorDelay()], config=SHORT_FITS,
                     progress=False)
    assert crit.verdict == "found" and crit.replication is not None, crit.table()
    assert crit.replication["gains"]["t0"] < 0 <= min(crit.replication["refit"].values()), crit.replication
    assert "refitted with the model's parameters as well" in crit.table() and "-> replicates" in crit.table()
