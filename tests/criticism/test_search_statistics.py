"""The catalog search's statistics on a linear model whose answer is known: one effect is found
alone, two effects that each hide the other are found through the pair, and a decoy is not named;
a point mass on an unknown rod is found at its place and charged for the choice; the second look
at the stage (criticism.revisit) finds an effect together with the component it lets in, and a
look at the second suspect finds the effect the missing component hid below a smaller one.

The test double is an EffectObjective whose residual is linear in θ (no physics), so the verdict
depends only on the search's rules (criticism.search, module docstring, step 3):

    r_s(θ) = y_s - A_s u(θ) - Σ_e c_e(η_e) B_{e,s},   c_e = 2 (η_e - lower_e) / width_e

u (15,) the T6 parameters in the unit box minus nominal, A_s (m, 15) small, B_e the effect's
signature (S, m), y = Σ_true c_e B_e + unit Gaussian noise. The signatures are orthogonal to A's
columns, so re-tuning the T6 cannot absorb them.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from criticism.candidate import rescore
from criticism.mismatch import MismatchConfig
from criticism.revisit import chosen, revisit_stage
from criticism.search import CriticismConfig, criticize, polish
from physics.effects import ActuatorDelay, AirDrag, CableAnchors, Effect, PointMass, SensorBias, model_space
from physics.objective import BatchResult
from physics.parameters import ParameterSpace

S, M = 8, 50
FIT = np.arange(S) < 6
T6 = ParameterSpace.t6()


class LinearEffects:
    """EffectObjective with the linear residual of the module docstring (loss "squared")."""

    loss = "squared"
    trajectories: list = []

    def __init__(self, y: np.ndarray, a: np.ndarray, signatures: dict[str, np.ndarray],
                 effects: Sequence[Effect] = ()) -> None:
        self.y, self.a, self.signatures = y, a, signatures
        self.effects = tuple(effects)
        self.space = model_space(self.effects)
        self.segments = tuple(f"t0/w{s}" for s in range(S))
        self.n_observations, self.noise_var = S * M, None

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        theta = np.asarray(theta, float)
        u = (theta[:T6.dim] - T6.nominal) / (T6.upper - T6.lower)
        r = self.y - self.a @ u
        for j in range(T6.dim, self.space.dim):
            p = self.space.parameters[j]
            r = r - 2.0 * (theta[j] - p.lower) / (p.upper - p.lower) * self.signatures[p.name]
        return [r[s][:, None] for s in range(S)]

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        return [self.residuals(t) for t in np.atleast_2d(thetas)]

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        return np.array([float((r ** 2).sum()) for r in self.residuals(theta)])

    def __call__(self, theta: np.ndarray) -> float:
        return float(self.evaluate_parts(theta).sum())

    def evaluate_batch(self, thetas: np.ndarray, *, on_result=None) -> BatchResult:
        parts = np.array([self.evaluate_parts(t) for t in np.atleast_2d(thetas)])
        n = len(parts)
        return BatchResult(parts.sum(axis=1), ("ok",) * n, np.zeros(n), ("",) * n, parts)

    def with_effects(self, effects: Sequence[Effect]) -> LinearEffects:
        return LinearEffects(self.y, self.a, self.signatures, effects)

    def fingerprint(self) -> dict:
        return {"segments": list(self.segments), "effects": [e.name for e in self.effects]}

    def close(self) -> None:
        pass


def _problem(truth: dict[str, float], seed: int = 0) -> tuple[LinearEffects, list[Effect]]:
    """Signatures air_drag = 3u + v, point_mass = -3u + w, actuator_delay (decoy) = z, each of |.|² =
    200 per direction; y = Σ truth[name] * signature + N(0, 1)."""
    rng = np.random.default_rng(seed)
    a = 0.1 * rng.standard_normal((S, M, T6.dim))
    basis = np.linalg.qr(np.c_[a.reshape(S * M, T6.dim), rng.standard_normal((S * M, 4))])[0][:, T6.dim:]
    u, v, w, z = (np.sqrt(200.0) * basis[:, k].reshape(S, M) for k in range(4))
    signatures = {"drag": 3 * u + v, "point_mass": -3 * u + w, "actuator_delay": z}
    names = {"air_drag": "drag", "point_mass": "point_mass", "actuator_delay": "actuator_delay"}
    y = rng.standard_normal((S, M)) + sum(c * signatures[names[e]] for e, c in truth.items())
    return LinearEffects(y, a, signatures), [AirDrag(), PointMass(), ActuatorDelay()]


def _criticize(truth: dict[str, float]):
    objective, effects = _problem(truth)
    return criticize(objective, T6.nominal, fit=FIT, held=~FIT, effects=effects,
                     config=CriticismConfig(grid=5, refine=5, joint=3), progress=False)


def test_one_effect_is_found_alone_without_the_pair() -> None:
    crit = _criticize({"air_drag": 1.0})
    assert crit.verdict == "found" and crit.found is not None and crit.found.name == "air_drag"
    assert crit.pair is None
    assert crit.found.values["drag"] == pytest.approx(10.0, abs=0.5)   # c = 1 at mid-box


def test_two_effects_that_hide_each_other_are_found_through_the_pair() -> None:
    """Each alone explains a few % at most (its 3u part is cancelled by the other's: the best
    multiple of 3u + v for v + w is 0.1), so neither passes alone;
    together they explain the signal v + w, and each has strong evidence given the other."""
    crit = _criticize({"air_drag": 1.0, "point_mass": 1.0})
    assert all(c.explained < 0.3 for c in crit.ranking), [(c.name, c.explained) for c in crit.ranking]
    assert crit.pair is not None and set(crit.pair["effects"]) == {"air_drag", "point_mass"}
    assert min(crit.pair["given"].values()) >= 10.0 and crit.pair["explained"] >= 0.3, crit.pair
    assert crit.verdict == "found" and crit.found is not None and crit.found.name in {"air_drag", "point_mass"}


def test_a_decoy_signature_with_no_signal_is_not_claimed() -> None:
    crit = _criticize({})
    assert crit.verdict == "unexplained" and crit.found is None
    assert crit.pair is None or min(crit.pair["given"].values()) < 10.0


class LinearPlaced(LinearEffects):
    """LinearEffects whose effect signatures depend on where the effect sits: keyed by
    ``"name@option,option"`` (Effect.config's options), e.g. "point_mass@3,-0.6"."""

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        theta = np.asarray(theta, float)
        u = (theta[:T6.dim] - T6.nominal) / (T6.upper - T6.lower)
        r, j = self.y - self.a @ u, T6.dim
        for effect in self.effects:
            key = effect.name + "@" + ",".join(str(v) for k, v in effect.config().items() if k != "effect")
            for p in effect.parameters():
                r = r - 2.0 * (theta[j] - p.lower) / (p.upper - p.lower) * self.signatures[key]
                j += 1
        return [r[s][:, None] for s in range(S)]

    def with_effects(self, effects: Sequence[Effect]) -> LinearPlaced:
        return LinearPlaced(self.y, self.a, self.signatures, effects)


def _placed_problem(rod: int | None, position: float, seed: int) -> LinearPlaced:
    """A point mass with an orthogonal signature (|.|² = 600) at each of its 12 placements; the data
    carry the one at (rod, position) at c = 1 (none when rod is None), plus unit noise."""
    rng = np.random.default_rng(seed)
    a = 0.1 * rng.standard_normal((S, M, T6.dim))
    basis = np.linalg.qr(np.c_[a.reshape(S * M, T6.dim), rng.standard_normal((S * M, 12))])[0][:, T6.dim:]
    places = PointMass(rod=None).placements()
    signatures = {f"point_mass@{p.rod},{p.position}": np.sqrt(600.0) * basis[:, k].reshape(S, M)
                  for k, p in enumerate(places)}
    y = rng.standard_normal((S, M))
    if rod is not None:
        y = y + signatures[f"point_mass@{rod},{position}"]
    return LinearPlaced(y, a, signatures)


def test_a_mass_on_an_unknown_rod_is_found_at_its_place_and_charged_for_the_choice() -> None:
    objective = _placed_problem(3, -0.6, seed=1)
    crit = criticize(objective, T6.nominal, fit=FIT, held=~FIT, effects=[PointMass(rod=None)],
                     config=CriticismConfig(grid=5, refine=5, joint=1), progress=False)
    assert crit.verdict == "found" and crit.found is not None
    assert (crit.found.config["rod"], crit.found.config["position"]) == (3, -0.6)
    assert crit.found.placements == 12
    uncharged = replace(crit.found, placements=1)
    charged = rescore(uncharged, (crit.base_fit, crit.base_held))
    assert charged.evidence - crit.found.evidence == pytest.approx(2 * np.log(12))
    assert "rod=3, position=-0.6; best of 12 places" in crit.table()


def test_twelve_places_to_choose_from_do_not_make_noise_a_mass() -> None:
    """Pure noise: the best of 12 screened placements is still not claimed, on 10 of 10 problems."""
    claims = [criticize(_placed_problem(None, 0.0, seed=s), T6.nominal, fit=FIT, held=~FIT,
                        effects=[PointMass(rod=None)], config=CriticismConfig(grid=5, refine=5, joint=1),
                        progress=False).found for s in range(10)]
    assert claims == [None] * 10


def _stage(effects: tuple, theta: np.ndarray | None = None, names: tuple = ()) -> SimpleNamespace:
    """A stand-in for a MismatchReport: the components kept, the θ it ends at and θ's names."""
    return SimpleNamespace(effects=effects, theta=theta, names=names)


def test_the_second_look_finds_an_effect_with_the_component_the_stage_rejected(monkeypatch) -> None:
    """The data carry a drag and cable anchors whose signatures share a part (3u + v, -3u + w):
    the model without anchors ranks the drag first but it explains too little alone; tried again
    with the drag in the model, the anchors are kept (the stand-in stage re-tunes both by least
    squares), and the pair is scored against the ranking's base and found."""
    rng = np.random.default_rng(3)
    a = 0.1 * rng.standard_normal((S, M, T6.dim))
    basis = np.linalg.qr(np.c_[a.reshape(S * M, T6.dim), rng.standard_normal((S * M, 3))])[0][:, T6.dim:]
    u, v, w = (np.sqrt(200.0) * basis[:, k].reshape(S, M) for k in range(3))
    signatures = {"drag": 3 * u + v, "anchor_offset": -3 * u + w}
    y = rng.standard_normal((S, M)) + signatures["drag"] + signatures["anchor_offset"]
    model = LinearEffects(y, a, signatures)
    crit = criticize(model, T6.nominal, fit=FIT, held=~FIT, effects=[AirDrag()],
                     config=CriticismConfig(grid=5, refine=5, joint=1), progress=False)
    assert crit.found is None and crit.ranking[0].name == "air_drag" and crit.ranking[0].evidence > 0

    def stage(objective, fit, held, *, config, journal_dir, progress, theta):
        assert [c.name for c in config.components] == ["cable_anchors"]      # only what the stage rejected
        extended = objective.with_effects(tuple(objective.effects) + (CableAnchors(),))
        fitted = polish(extended, np.r_[theta, 0.0], fit)
        order = [*range(T6.dim), extended.space.dim - 1, extended.space.dim - 2]  # the stage's own effect order
        return _stage((CableAnchors(),), fitted.theta[order], tuple(np.array(extended.space.names)[order]))

    monkeypatch.setattr("criticism.revisit.journalled_stage", stage)
    first = _stage((SensorBias(),))
    config = MismatchConfig(components=(SensorBias(), CableAnchors()))
    (second,) = revisit_stage(model, crit, first, FIT, ~FIT, [], config=config, criticism=CriticismConfig())
    assert second.found and [e.name for e in second.components] == ["cable_anchors"]
    assert second.row.explained >= 0.3 and second.row.evidence >= 10 and set(second.row.values) == {"drag",
                                                                                                "anchor_offset"}
    assert "kept cable_anchors" in second.text() and "-> found" in second.text()
    assert second.alone == crit.ranking[0].values and second.as_dict()["alone"] == second.alone
    assert revisit_stage(model, crit, _stage(()), FIT, ~FIT, [], config=config, criticism=CriticismConfig()) == ()
    only_top = MismatchConfig(components=(SensorBias(), AirDrag()))
    assert revisit_stage(model, crit, first, FIT, ~FIT, [], config=only_top, criticism=CriticismConfig()) == ()


def test_a_look_at_the_second_suspect_finds_the_effect_the_missing_component_hid(monkeypatch) -> None:
    """The data carry a small drag, a delay (3u + w) and cable anchors (-2.5u + z): without the
    anchors the delay's fit cancels most of itself, so the drag ranks first and the delay second,
    neither found. A second look at the top suspect alone (the drag with the anchors) finds nothing;
    with ``suspects=2`` the delay gets a look too, is found with the anchors, and is the look the
    pass takes. Each suspect's stage has its own journal."""
    rng = np.random.default_rng(3)
    a = 0.1 * rng.standard_normal((S, M, T6.dim))
    basis = np.linalg.qr(np.c_[a.reshape(S * M, T6.dim), rng.standard_normal((S * M, 4))])[0][:, T6.dim:]
    u, v, w, z = (np.sqrt(200.0) * basis[:, k].reshape(S, M) for k in range(4))
    signatures = {"drag": v, "actuator_delay": 3 * u + w, "anchor_offset": -2.5 * u + z}
    model = LinearEffects(rng.standard_normal((S, M)) + sum(signatures.values()), a, signatures)
    crit = criticize(model, T6.nominal, fit=FIT, held=~FIT, effects=[AirDrag(), ActuatorDelay()],
                     config=CriticismConfig(grid=5, refine=5, joint=1), progress=False)
    assert crit.found is None and [c.name for c in crit.ranking] == ["air_drag", "actuator_delay"]
    journals: list = []
    journal = Path("journals") / "revisit0"

    def stage(objective, fit, held, *, config, journal_dir, progress, theta):
        journals.append(journal_dir)
        extended = objective.with_effects(tuple(objective.effects) + (CableAnchors(),))
        fitted = polish(extended, np.r_[theta, 0.0], fit)
        return _stage((CableAnchors(),), fitted.theta, tuple(extended.space.names))

    monkeypatch.setattr("criticism.revisit.journalled_stage", stage)
    first, config = _stage((SensorBias(),)), MismatchConfig(components=(SensorBias(), CableAnchors()))
    (top,) = revisit_stage(model, crit, first, FIT, ~FIT, [], config=config, criticism=CriticismConfig())
    assert top.effect == "air_drag" and not top.found and chosen((top,)) is top
    journals.clear()
    looks = revisit_stage(model, crit, first, FIT, ~FIT, [], config=config, criticism=CriticismConfig(),
                          suspects=2, journal_dir=journal)
    assert [look.effect for look in looks] == ["air_drag", "actuator_delay"] and looks[1].found
    assert looks[1].row.evidence > looks[0].row.evidence and chosen(looks) is looks[1]
    assert journals == [journal, journal.with_name("revisit0-1")]
    assert chosen(()) is None
