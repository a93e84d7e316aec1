"""The mismatch stage: model components that make the model reproduce another engine's (or robot's)
data, found and added before the effect search.

Criticism credits an effect with the held-out error it removes beyond the re-tuned model. When
the model and the source of the data differ in a *component* (the actuator's law, the shape of
the end caps), that difference leaves a residual far above the model's own floor, and no effect
smaller than it can win. This stage runs first, on fit trajectories F and held-out ones H:

1. **base**: the model at θ0 re-tuned on F (bounded least squares over its parameters,
   :func:`criticism.search.polish`; ``rod_length`` is set to the length the data show and held,
   :func:`measured_rod_length`): θ_b, fit error E_F(θ_b);
2. **trials**: each round first re-tunes the model so far once more from the trials' starts (the
   null trial, ``null_trial``) and keeps that θ if it fits F better, so that a component is
   credited only with what it adds beyond a better re-tuning; then each component c of
   ``MismatchConfig.components`` (an Effect that replaces or reshapes a part of the model) is
   added and (θ, η_c) is re-tuned jointly on F from (θ_b, η_c's nominal); its gain is
   g_c = 1 − E_F(c) / E_F(model so far);
3. **keep** the component with the largest gain if g_c ≥ ``min_gain`` and its one-step error on
   F (horizon 1, every prediction from an observed state) is at most (1 + ``max_one_step_rise``)
   times the model's before it (else the next by gain), and try the others again on the model
   that has it (``rounds``). A component that buys windowed fit with a local law the data
   contradict raises the one-step error, on F and on held-out data alike (docs/diagnose.md, "The
   one-step guard"). The decision uses F only, so the held-out figures below stay out of sample;
4. **report** on H, before (θ_b) and after (the augmented model at its re-tuned θ): the one-step
   error Σ||x_{i+1} − f(x_i, u_i, θ)||² (horizon 1), the objective's windowed error, and the
   open-loop drift at ``drift_time`` (mean node distance [m] of one free rollout from the first
   sample); where the residual lives after (phase, nodes, axes, frequency bands,
   :func:`criticism.held_out.localize`); the parameters the re-tuning left at a bound of the box (belief.bounds).

The components replace parts criticism never tries against each other: once an actuator is
swapped, the catalog's other actuator replacements are dropped from the search
(:func:`superseded`).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from belief.bounds import AT_BOUND_TOLERANCE, AtBound, at_bounds
from belief.least_squares import LeastSquaresConfig
from criticism.errors import CriticismError
from criticism.held_out import HeldScores, held_scores, localize, one_step_error, where_text
from criticism.search import CriticismConfig, polish
from physics.effects import CableAnchors, EndCapRadius, RollingResistance, TensionLimitedActuation, effect_from_config
from physics.effects.base import Effect
from physics.trajectory_objective import TrajectoryObjective

__all__ = ["MismatchConfig", "Trial", "MismatchReport", "absorb_mismatch", "superseded", "in_order",
           "measured_rod_length"]

#: Effects that replace the same component: at most one of each group in a model.
COMPONENT_GROUPS: tuple[frozenset[str], ...] = (frozenset({"rate_limited_actuator", "tension_limited_actuator"}),
                                                 frozenset({"cable_anchors", "fixed_anchors"}))


def _default_components() -> tuple[Effect, ...]:
    return (TensionLimitedActuation(), CableAnchors(), EndCapRadius(), RollingResistance())


@dataclass(frozen=True)
class MismatchConfig:
    """components: the component changes tried (physics.effects instances); min_gain: the fraction
    of the fit error a component must remove to be kept; max_one_step_rise: the most its one-step
    error on the fit trajectories may rise, as a fraction (module docstring, step 3); rounds: most
    components kept;
    drift_time [s]: when the open-loop drift is read; local: the least-squares re-tuning;
    bound_tolerance: fraction of the box width within which a value is at a bound; hold_measured:
    set ``rod_length`` to the data's node distance and hold it (:func:`measured_rod_length`);
    null_trial: re-tune the model so far at the start of each round (module docstring, step 2)."""

    components: tuple[Effect, ...] = field(default_factory=_default_components)
    min_gain: float = 0.1
    max_one_step_rise: float = 0.1
    rounds: int = 3
    drift_time: float = 0.5
    local: LeastSquaresConfig = field(default_factory=LeastSquaresConfig)
    bound_tolerance: float = AT_BOUND_TOLERANCE
    hold_measured: bool = True
    null_trial: bool = True

    def __post_init__(self) -> None:
        if not (0.0 < self.min_gain < 1.0 and self.max_one_step_rise >= 0 and self.rounds >= 0
                and self.drift_time > 0):
            raise CriticismError(f"MismatchConfig needs 0 < min_gain < 1, max_one_step_rise >= 0, rounds >= 0 and "
                                 f"drift_time > 0 s, got {self.min_gain!r}, {self.max_one_step_rise!r}, "
                                 f"{self.rounds!r}, {self.drift_time!r}.")
        if not all(isinstance(c, Effect) for c in self.components):
            raise CriticismError("MismatchConfig.components must be physics.effects.Effect instances.")

    def record(self) -> dict[str, Any]:
        """The settings as a JSON-able dict (the components by their configs)."""
        return {"components": [c.config() for c in self.components], "min_gain": self.min_gain,
                "max_one_step_rise": self.max_one_step_rise, "rounds": self.rounds, "drift_time": self.drift_time,
                "local": self.local.record(),
                "bound_tolerance": self.bound_tolerance, "hold_measured": self.hold_measured,
                **({"null_trial": True} if self.null_trial else {})}


@dataclass(frozen=True)
class Trial:
    """One component tried in a round: its fitted parameters, the fit error after the joint
    re-tuning, its gain over the model of that round, whether it was kept, the full θ, and its
    one-step error on the fit trajectories over the model's of that round (None when its gain was
    not high enough to ask)."""

    round: int
    name: str
    values: dict[str, float]
    fit_error: float
    gain: float
    kept: bool
    theta: tuple[float, ...]
    one_step: float | None = None


@dataclass
class MismatchReport:
    """The stage's outcome (module docstring): the kept components, the augmented model's re-tuned
    θ and parameter names, θ_b, every trial, the held-out scores before and after, where the
    residual lives before and after, the parameters at a bound after, and whether the scores are
    in-sample (no trajectory held out)."""

    effects: tuple[Effect, ...]
    names: tuple[str, ...]
    theta: np.ndarray
    base_theta: np.ndarray
    trials: list[Trial]
    before: HeldScores
    after: HeldScores
    where_before: dict[str, Any]
    where_after: dict[str, Any]
    at_bounds: tuple[AtBound, ...]
    in_sample: bool = False

    def ratios(self) -> dict[str, float]:
        """after / before of the totals (one-step, windows, drift)."""
        b, a = self.before.totals(), self.after.totals()
        return {k: a[k] / b[k] if b[k] > 0 else float("nan") for k in b}

    def text(self) -> str:
        """The stage as a few lines of text: trials, scores before and after, where the residual lives, bounds."""
        lines = ["mismatch stage: " + (", ".join(e.name for e in self.effects) or "no component kept")]
        for t in self.trials:
            size = ", ".join(f"{k}={v:.4g}" for k, v in t.values.items()) or "no parameter"
            one = f"  one-step {t.one_step:.2f}x" if t.one_step is not None else ""
            lines.append(f"  round {t.round}: {t.name:26s} fit error {t.fit_error:.4g} gain {t.gain:6.1%}  {size}"
                         + one + ("  <- kept" if t.kept else ""))
        b, a, r = self.before.totals(), self.after.totals(), self.ratios()
        scope = "in-sample (nothing held out)" if self.in_sample else "held-out"
        lines.append(f"  {scope} one-step error {b['one_step']:.4g} -> {a['one_step']:.4g} ({r['one_step']:.2f}x); "
                     f"windowed {b['windows']:.4g} -> {a['windows']:.4g} ({r['windows']:.2f}x); drift "
                     f"{1e3 * b['drift']:.1f} -> {1e3 * a['drift']:.1f} mm ({r['drift']:.2f}x)")
        lines.append("  residual after: " + where_text(self.where_after))
        for bound in self.at_bounds:
            lines.append(f"  {bound.name} at its {bound.side} bound {bound.bound:.4g} {bound.unit}")
        return "\n".join(lines)

    def as_dict(self) -> dict[str, Any]:
        """A JSON-able record of the stage."""
        return {"effects": [e.config() for e in self.effects], "names": list(self.names),
                "theta": self.theta.tolist(), "base_theta": self.base_theta.tolist(),
                "trials": [vars(t) for t in self.trials], "before": vars(self.before), "after": vars(self.after),
                "ratios": self.ratios(), "where_before": self.where_before, "where_after": self.where_after,
                "at_bounds": [vars(b) for b in self.at_bounds], "in_sample": self.in_sample}

    @classmethod
    def from_dict(cls, record: dict[str, Any]) -> MismatchReport:
        """The report back from :meth:`as_dict` (e.g. read from the stage's journal)."""
        return cls(tuple(effect_from_config(c) for c in record["effects"]), tuple(record["names"]),
                   np.asarray(record["theta"], float), np.asarray(record["base_theta"], float),
                   [Trial(**{**t, "theta": tuple(t["theta"])}) for t in record["trials"]],
                   HeldScores(**record["before"]), HeldScores(**record["after"]), record["where_before"],
                   record["where_after"], tuple(AtBound(**b) for b in record["at_bounds"]), record["in_sample"])


def superseded(effects: Sequence[Effect], kept: Sequence[Effect]) -> list[Effect]:
    """``effects`` without those that replace a component one of ``kept`` already replaced
    (COMPONENT_GROUPS, Effect.replaces) or that are already in ``kept``."""
    taken = {e.name for e in kept}
    blocked = set(taken).union(*(group for group in COMPONENT_GROUPS if group & taken), *(e.replaces for e in kept))
    return [e for e in effects if e.name not in blocked]


def measured_rod_length(objective: TrajectoryObjective) -> float:
    """The rod length the data show [m]: the median over samples and rods of |x_{2i+1} - x_{2i}|.

    Every prediction starts from observed nodes, and a model rod of another length misplaces both
    its nodes in every sample; a re-tuning on open-loop windows would trade that offset for
    dynamics it cannot otherwise match, so the stage holds rod_length at this value."""
    lengths = [np.linalg.norm(np.asarray(ds["nodes"].values, float)[:, 1::2] - np.asarray(ds["nodes"].values,
                                                                                          float)[:, 0::2], axis=2)
               for ds in objective.trajectories]
    return float(np.nanmedian(np.concatenate([v.ravel() for v in lengths])))


def _held(objective: TrajectoryObjective, config: MismatchConfig) -> set[str]:
    return {"rod_length"} if config.hold_measured and "rod_length" in objective.space.names else set()


def _retune(objective: TrajectoryObjective, theta: np.ndarray, fit: np.ndarray,
            config: MismatchConfig) -> tuple[np.ndarray, float]:
    """θ re-tuned on the fit segments by least squares, held parameters (:func:`_held`) kept; (θ, E_F)."""
    held = _held(objective, config)
    indices = [j for j, name in enumerate(objective.space.names) if name not in held]
    result = polish(objective, theta, fit, CriticismConfig(local=config.local), indices=indices)
    return np.asarray(result.theta, float), float(result.error)


def in_order(effects: Sequence[Effect], order: Sequence[str]) -> tuple[Effect, ...]:
    """``effects`` sorted by their names' place in ``order`` (the stage's components), those not in
    it last in their own order: an actuator replacement comes before the effects that wrap it."""
    rank = {name: k for k, name in enumerate(order)}
    return tuple(sorted(effects, key=lambda e: rank.get(e.name, len(rank))))


def _extend(objective: TrajectoryObjective, thetas: Sequence[np.ndarray], effect: Effect, order: Sequence[str],
            fit: np.ndarray) -> tuple[TrajectoryObjective, np.ndarray]:
    """``objective`` with ``effect`` added, its effects sorted by their place in ``order`` (an
    actuator replacement before the effects that wrap the actuator), and the start of its
    re-tuning: of ``thetas`` (each (D,), carried over by parameter name, the new parameters at
    their data-read start, Effect.start) the one with the lowest error on the ``fit`` segments. The model's
    re-tuned θ was tuned for the component being replaced (a motor model's parameters stand in
    for what it lacks), so the stage's own start θ0 is the other candidate."""
    extended = objective.with_effects(in_order((*objective.effects, effect), order))
    starts = []
    for theta in thetas:
        values = dict(zip(objective.space.names, np.asarray(theta, float).tolist(), strict=True))
        values.update(effect.start(objective.trajectories))
        starts.append(np.array([values[n] for n in extended.space.names]))
    return extended, _best_start(extended, starts, fit)


def _best_start(objective: TrajectoryObjective, starts: Sequence[np.ndarray], fit: np.ndarray) -> np.ndarray:
    """Of ``starts`` (each (D,)), the one with the lowest error on the ``fit`` segments (the first
    if none evaluates)."""
    scores = objective.evaluate_batch(np.array(starts))
    ok = [k for k, status in enumerate(scores.status) if status == "ok"]
    best = min(ok, key=lambda k: float(np.nansum(scores.parts[k][fit]))) if ok else 0
    return np.asarray(starts[best], float)


def _null_trial(objective: TrajectoryObjective, thetas: Sequence[np.ndarray], error: float, fit: np.ndarray,
                config: MismatchConfig) -> tuple[np.ndarray, float]:
    """The model so far (re-tuned at thetas[0], E_F = ``error``) re-tuned once more from the best of
    ``thetas`` (each (D,)) on the fit segments; (θ, E_F) of whichever of the two fits better."""
    theta, fit_error = _retune(objective, _best_start(objective, thetas, fit), fit, config)
    return (theta, fit_error) if fit_error < error else (np.asarray(thetas[0], float), error)


def _round(objective: TrajectoryObjective, thetas: Sequence[np.ndarray], error: float, fit: np.ndarray,
           candidates: Sequence[Effect], config: MismatchConfig, k: int,
           progress: bool) -> list[tuple[Trial, TrajectoryObjective]]:
    """Each candidate added to ``objective`` (re-tuned at thetas[0], E_F = ``error``; the other
    thetas are alternative starts, :func:`_extend`) and re-tuned jointly: its trial and the
    extended objective."""
    order = [c.name for c in config.components]
    out = []
    for effect in tqdm(candidates, desc=f"mismatch round {k}", leave=False, disable=not progress):
        extended, start = _extend(objective, thetas, effect, order, fit)
        fitted, fit_error = _retune(extended, start, fit, config)
        values = {p.name: float(fitted[extended.space.names.index(p.name)]) for p in effect.parameters()}
        trial = Trial(k, effect.name, values, fit_error, 1.0 - fit_error / error, False, tuple(fitted.tolist()))
        out.append((trial, extended))
    return out


def _choose(model: TrajectoryObjective, theta: np.ndarray, tried: Sequence[tuple[Trial, TrajectoryObjective]],
            config: MismatchConfig) -> tuple[int | None, dict[int, float]]:
    """The index into ``tried`` of the component kept (module docstring, step 3; None: none) and the
    one-step ratios asked on the way, E1_F(extended at its θ) / E1_F(``model`` at θ (D,))."""
    everything = range(len(model.trajectories))
    before: float | None = None
    rises: dict[int, float] = {}
    for j in sorted(range(len(tried)), key=lambda j: -tried[j][0].gain):
        trial, extended = tried[j]
        if trial.gain < config.min_gain:
            break
        before = one_step_error(model, theta, everything) if before is None else before
        rises[j] = one_step_error(extended, np.asarray(trial.theta, float), everything) / max(before, 1e-300)
        if rises[j] <= 1.0 + config.max_one_step_rise:
            return j, rises
    return None, rises


def _fit_view(objective: TrajectoryObjective, fit: np.ndarray) -> tuple[TrajectoryObjective, np.ndarray, list[int]]:
    """The objective on the trajectories with a fit segment only (a re-tuning then never simulates a
    held-out flop), the fit mask over its segments, and the trajectories scored in-sample."""
    traj = np.array([int(s.split("/")[0][1:]) for s in objective.segments])
    used = sorted({int(t) for t in traj[fit]})
    return objective.select(used), fit[np.isin(traj, used)], used


def absorb_mismatch(objective: TrajectoryObjective, fit: np.ndarray | Sequence[bool], held: Sequence[int], *,
                    theta: np.ndarray | None = None, config: MismatchConfig = MismatchConfig(),
                    progress: bool = True) -> MismatchReport:
    """Run the stage of the module docstring on ``objective`` (its loss must be "squared").

    fit: mask (S,) over the objective's segments the re-tuning uses; held: indices of the held-out
    trajectories that are scored (empty: the fit trajectories are scored, in-sample); theta: the
    start θ0 (D,) (default: the space's nominal θ; with ``hold_measured`` its rod_length is the data's)."""
    fit_mask = np.asarray(fit, bool)
    if fit_mask.shape != (len(objective.segments),) or not fit_mask.any():
        raise CriticismError(f"fit must be a non-empty boolean mask over the {len(objective.segments)} segments.")
    if objective.loss != "squared":
        raise CriticismError("the mismatch stage needs TrajectoryObjective(..., loss='squared').")
    model, fit_mask, fitted_on = _fit_view(objective, fit_mask)
    start = np.array(objective.space.nominal if theta is None else theta, float)
    if _held(objective, config):
        j = list(objective.space.names).index("rod_length")
        start[j] = np.clip(measured_rod_length(model), objective.space.lower[j], objective.space.upper[j])
    scored = list(held) or fitted_on
    base_theta, error = _retune(model, start, fit_mask, config)
    current, trials = base_theta, []
    for k in range(1, config.rounds + 1):
        restart = np.array([dict(zip(objective.space.names, start, strict=True)).get(n, v)
                            for n, v in zip(model.space.names, current, strict=True)])
        if config.null_trial:
            current, error = _null_trial(model, [current, restart], error, fit_mask, config)
            base_theta = current if k == 1 else base_theta
        tried = _round(model, [current, restart], error, fit_mask, superseded(config.components, model.effects),
                       config, k, progress)
        if not tried:
            break
        best, rises = _choose(model, current, tried, config)
        trials += [replace(t, kept=j == best, one_step=rises.get(j)) for j, (t, _) in enumerate(tried)]
        if best is None:
            break
        trial, model = tried[best]
        current, error = np.asarray(trial.theta, float), trial.fit_error
    bounds = at_bounds(model.space, current, tolerance=config.bound_tolerance, source="re-tuning")
    added = tuple(e for e in model.effects if e not in objective.effects)
    after = objective.with_effects(model.effects)
    return MismatchReport(added, model.space.names, current, base_theta,
                          trials, held_scores(objective, base_theta, scored, config.drift_time),
                          held_scores(after, current, scored, config.drift_time),
                          localize(objective, base_theta, scored), localize(after, current, scored), tuple(bounds),
                          in_sample=not list(held))
