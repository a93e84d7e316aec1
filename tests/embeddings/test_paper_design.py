"""benchmarks/paper_design.py draws the initial designs that benchmarks/paper.py's searches evaluate first."""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

from paper import Settings  # noqa: E402
from paper_design import best_so_far, designs  # noqa: E402

from belief import Grid, SobolCandidates, identify  # noqa: E402
from embeddings import REMBO, Identity  # noqa: E402
from physics.parameters import ParameterSpace  # noqa: E402


def _first(decoder, grid, budget: int, seed: int, n: int) -> np.ndarray:
    """θ of the first ``n`` calls of a cheap objective by BO as paper.py runs it (paper.py's Recorder
    logs the calls in the same order; the journal's history sorts a batch by cell)."""
    space = decoder.space
    target = space.to_unit(space.nominal[None])[0] + 0.1
    calls: list[np.ndarray] = []

    def objective(theta: np.ndarray) -> float:
        calls.append(np.array(theta, dtype=float))
        return float(np.sum((space.to_unit(np.atleast_2d(theta))[0] - target) ** 2))

    objective.space = space  # type: ignore[attr-defined]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        identify(objective, decoder, grid, budget=budget, seed=seed, proposer="bo", progress=False, posterior=None)
    return np.array(calls[:n])


def test_designs_are_the_points_the_searches_evaluate_first() -> None:
    """The full-space design is bo-15's first batch, the latent one the hand-over's, for each seed."""
    space, settings = ParameterSpace.t6(), Settings()
    latent = REMBO(space, dim=5, seed=0)
    for seed in (0, 3):
        drawn = designs(space, latent, settings, seed, 5)
        full = SobolCandidates.for_decoder(Identity(space), n=settings.candidates, seed=seed)
        np.testing.assert_allclose(drawn["full"], _first(Identity(space), full, 16, seed, 5))
        grid = Grid.for_decoder(latent, points_per_dim=settings.points_per_dim)
        np.testing.assert_allclose(drawn["latent"], _first(latent, grid, settings.handoff, seed, 5))
        assert not np.allclose(drawn["full"], designs(space, latent, settings, seed + 1, 5)["full"])


def test_best_so_far_scores_the_point_of_lowest_fitted_error() -> None:
    fit, held = np.array([3.0, 1.0, 2.0, 0.5]), np.array([10.0, 100.0, 1.0, 1000.0])
    np.testing.assert_allclose(best_so_far(fit, held), [1.0, 2.0, 2.0, 3.0])


def test_paper_runs_each_belief_method_as_a_library_preset(monkeypatch) -> None:
    import paper

    import belief.presets as presets

    calls: list[tuple[str, object]] = []

    def record(objective, preset, **kwargs):
        calls.append((preset.name, kwargs["decoder"]))
        return None

    monkeypatch.setattr(presets, "run_preset", record)
    space, settings = ParameterSpace.t6(), Settings()

    class Stub:
        count_residuals = False

    decoders = {name: object() for name in paper.TRAINED}
    belief_methods = [m for m in paper.METHODS if m not in paper.PEERS]
    for name in belief_methods:
        paper.run_method(name, Stub(), space, decoders, settings, seed=0)
    assert [name for name, _ in calls] == [paper.PRESET_OF[m][0] for m in belief_methods]
    assert dict(zip(belief_methods, (d for _, d in calls)))["ae-cf-bo-gn"] is decoders["ae-cf-5"]
    best = paper.method_preset("ae-cf-bo-gn", space, settings)
    assert best == presets.PRESETS[presets.DEFAULT_PRESET]       # the paper's best is the library default
