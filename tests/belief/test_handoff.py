"""belief.handoff: evaluations of one latent space carried into BO over another, without re-simulating."""
from __future__ import annotations

import numpy as np
import pytest

from belief import BeliefError, BudgetError, Grid, JournalError, carry_over, continue_in, identify
from embeddings import REMBO, Identity


class Counting:
    """An objective that counts its calls."""

    def __init__(self, inner) -> None:
        self.inner, self.space, self.calls = inner, inner.space, 0

    def __call__(self, theta: np.ndarray) -> float:
        self.calls += 1
        return self.inner(theta)


@pytest.fixture
def first(branin15):
    """Stage 1: BO over a REMBO 5-D grid, 8 evaluations."""
    objective = Counting(branin15)
    decoder = REMBO(objective.space, dim=5, seed=0)
    result = identify(objective, decoder, Grid.for_decoder(decoder, points_per_dim=5), budget=8, seed=0,
                      posterior=None, progress=False)
    return objective, result


def test_stage_two_starts_from_the_carried_evaluations_and_repeats_none(first) -> None:
    objective, result = first
    calls = objective.calls
    second = continue_in(result, objective, Identity(objective.space), budget=14, seed=0, n=256, posterior=None,
                         progress=False)
    assert objective.calls - calls == 6
    hist, old = second.history, result.history
    assert second.n_evaluations == 14
    np.testing.assert_array_equal(hist["theta"].values[:8], old["theta"].values)
    np.testing.assert_array_equal(hist["error"].values[:8], old["error"].values)
    assert set(hist["cell"].values[:8]) == set(range(8)) and np.all(hist["cell"].values[8:] >= 8)
    assert second.best_error <= result.best_error


def test_a_journalled_stage_two_resumes_and_refuses_other_carried_data(first, tmp_path) -> None:
    objective, result = first
    path = tmp_path / "stage2.sqlite"
    run = lambda prev: continue_in(prev, objective, Identity(objective.space), budget=12, seed=1, n=128,  # noqa: E731
                                   posterior=None, progress=False, journal=path)
    a = run(result)
    calls = objective.calls
    b = run(result)
    assert objective.calls == calls
    np.testing.assert_array_equal(a.history["theta"].values, b.history["theta"].values)
    result.history["error"].values[0] *= 2
    with pytest.raises(JournalError, match="carried"):
        run(result)


def test_carry_over_checks_the_decoder_and_the_budget(first) -> None:
    objective, result = first
    with pytest.raises(BeliefError, match="decode"):
        carry_over(result, REMBO(objective.space, dim=5, seed=3), n=64, seed=0)
    carried = carry_over(result, Identity(objective.space), n=64, seed=0)
    assert carried.grid.size == 64 + 8 and len(carried.records) == 8
    np.testing.assert_array_equal(np.array([r.z for r in carried.records]), carried.grid.points[:8])
    with pytest.raises(BudgetError, match="carried"):
        continue_in(result, objective, Identity(objective.space), budget=8, seed=0, n=64, progress=False)
    with pytest.raises(BudgetError, match="n_init"):
        identify(objective, Identity(objective.space), carried.grid, budget=10, seed=0, n_init=4,
                 carry=carried.records, progress=False)


def test_failed_evaluations_are_carried_as_failed_and_never_proposed_again(branin15) -> None:
    from physics.errors import PhysicsError

    def objective(theta: np.ndarray) -> float:
        if theta[3] > 0.6:
            raise PhysicsError("diverged (test)")
        return branin15(theta)

    objective.space = branin15.space
    decoder = REMBO(branin15.space, dim=5, seed=0)
    first = identify(objective, decoder, Grid.for_decoder(decoder, points_per_dim=5), budget=8, seed=0,
                     posterior=None, progress=False)
    failed = int((first.history["status"].values != "ok").sum())
    assert 0 < failed < 8
    second = continue_in(first, objective, Identity(branin15.space), budget=12, seed=0, n=128, posterior=None,
                         progress=False)
    status = second.history["status"].values
    np.testing.assert_array_equal(status[:8], first.history["status"].values)
    assert len(set(second.history["cell"].values)) == 12
