"""Every proposer (belief.proposers.Proposer) passes the same checks.

A new proposer is one line in IMPLEMENTATIONS (a factory taking the seed). The history is the
bowl E(z) = |z - (0.3, 0.7)|² evaluated at the proposed cells of a 7 x 7 grid on the unit square.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

import belief.proposers as proposers
from belief.driver import Budget, run
from belief.grid import Grid
from belief.journal import Record
from belief.proposers import BOProposer, Proposer, RandomProposer, SobolDesign, WarmStart
from belief.surrogate import SurrogateConfig
from embeddings import Identity
from physics.objective import FunctionObjective
from physics.parameters import Parameter, ParameterSpace

IMPLEMENTATIONS = [
    pytest.param(RandomProposer, id="RandomProposer"),
    pytest.param(SobolDesign, id="SobolDesign"),
    pytest.param(lambda seed: WarmStart([24, 3], SobolDesign(seed)), id="WarmStart"),
    pytest.param(BOProposer, id="BOProposer"),
    pytest.param(lambda seed: BOProposer(seed, initial=WarmStart([0], RandomProposer(seed)),
                                          surrogate=SurrogateConfig(impute_failed=True)),
                 id="BOProposer-warm-imputed"),
]
GRID = Grid([[0.0, 1.0], [0.0, 1.0]], points_per_dim=7)
SPACE = ParameterSpace((Parameter("a", "1", 0.5, 0.0, 1.0, minimum=-1.0), Parameter("b", "1", 0.5, 0.0, 1.0,
                                                                                   minimum=-1.0)))


@pytest.fixture(params=IMPLEMENTATIONS)
def make(request):
    return request.param


def _bowl(z: np.ndarray) -> float:
    return float(((np.asarray(z) - np.array([0.3, 0.7])) ** 2).sum())


def _history(cells: list[int], batch: int = 0, failed: tuple[int, ...] = ()) -> list[Record]:
    """Records of the cells; those in ``failed`` diverged."""
    out = []
    for c in cells:
        z = tuple(float(v) for v in GRID.points[c])
        if c in failed:
            out.append(Record(batch, c, z, z, float("nan"), 0.0, "diverged", "PhysicsError: boom"))
        else:
            out.append(Record(batch, c, z, z, _bowl(z), 0.0, "ok", "", (_bowl(z),)))
    return out


def _check_cells(cells: list[int], size: int, history: list[Record]) -> None:
    assert len(cells) == size == len(set(cells)) and all(isinstance(c, int) for c in cells)
    assert all(0 <= c < GRID.size for c in cells) and not {r.cell for r in history} & set(cells)


def test_every_proposer_of_belief_is_checked() -> None:
    classes = {name for name, cls in vars(proposers).items()
               if isinstance(cls, type) and cls.__module__ == proposers.__name__ and hasattr(cls, "propose")
               and cls is not Proposer}
    assert classes <= {"RandomProposer", "SobolDesign", "WarmStart", "BOProposer"}, "add it to IMPLEMENTATIONS"


def test_config_is_json_and_names_the_options(make) -> None:
    proposer = make(0)
    assert isinstance(proposer, Proposer)
    config = proposer.config()
    assert json.loads(json.dumps(config)) == config and isinstance(config["kind"], str)
    assert make(0).config() == config != make(1).config()


def test_the_first_batch_is_distinct_cells_and_a_function_of_the_seed(make) -> None:
    proposal = make(0).propose(0, [], 6, GRID)
    _check_cells(proposal.cells, 6, [])
    assert make(0).propose(0, [], 6, GRID).cells == proposal.cells


def test_later_batches_skip_the_history_and_are_a_function_of_it(make) -> None:
    first = make(0).propose(0, [], 6, GRID).cells
    history = _history(first, failed=(first[1],))
    proposal = make(0).propose(1, history, 3, GRID)
    _check_cells(proposal.cells, 3, history)
    assert make(0).propose(1, history, 3, GRID).cells == proposal.cells
    if proposal.prediction is not None:                 # a model-based proposer's prediction covers every cell
        mean, var = proposal.prediction
        assert mean.shape == var.shape == (GRID.size,) and (var >= 0).all()


def test_the_last_cells_fill_the_batch(make) -> None:
    remaining = [5, 40]
    history = _history([c for c in range(GRID.size) if c not in remaining], failed=(7,))
    assert sorted(make(0).propose(3, history, 2, GRID).cells) == remaining


def test_the_driver_runs_it_to_the_budget_deterministically(make) -> None:
    objective = FunctionObjective(_bowl, SPACE)

    def once():
        return run(objective, Identity(SPACE), GRID, make(2), Budget(11, None, 5, 2), journal=None, progress=False)

    a, b = once(), once()
    assert a.stopped == "budget" and [r.batch for r in a.records] == [0] * 5 + [1, 1, 2, 2, 3, 3]
    assert len({r.cell for r in a.records}) == 11 and all(r.status == "ok" for r in a.records)
    assert [r.cell for r in a.records] == [r.cell for r in b.records]
