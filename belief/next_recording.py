"""What to record next: the flop whose data would most narrow what the data at hand leave widest.

Coordinates are relative changes x_j = log θ_j around θ̂ (as belief.identifiability: dx_j =
width_j du_j / s_j, s_j = |θ̂_j|, or the box's width for a parameter at 0), so widths read in % of
the value.

Information now::

    F_now = F_data + F_m + Π,   F_data = J_xᵀ J_x / σ²

J_x is the data's residual Jacobian in x at θ̂ (forward differences of relative step ``step``, one
batch of D + 1 evaluations), σ² the likelihood's variance per residual that P used, F_m = T Gᵀ G T
the measurements' rows (physics.measurements; T = diag(s / width)) and Π = diag(12 (s_j /
width_j)²) the box's precision (a uniform prior's variance per axis). A run that ended with the
local stage hands its map's F_x (data and measurements, as P saw them) instead of J.

C = F_now⁻¹. The mass–force scale (physics.scaling: every mass and force times one factor leaves
the motion unchanged, so no motion can narrow it, a weighed rod can) is left out unless something
was measured: Q (D x D') spans what a motion can narrow.

A candidate a (physics.candidate_recordings: a flop from the resting face, simulated at θ̂ the way
the data were recorded) brings F_a = G_aᵀ G_a / σ², G_a its residuals' Jacobian in x (D + 1
evaluations, all candidates in one objective). When σ² was set by the model-error floor
δ E_min / 2 (belief.noise, belief.scale), σ² grows with E and so with the data: the data's
information is then scaled by c = K / (K + K_a) (K, K_a residuals now and of the motion), else
c = 1. After it::

    C_a = (c (F_data + F_a) + F_m + Π)⁻¹
    gain_a = ½ log det(Qᵀ C Q) − ½ log det(Qᵀ C_a Q)        [nats]

the expected information the motion brings (a D-optimal design, Atkinson & Donev, "Optimum
Experimental Designs"). The candidate with the largest gain is suggested when it brings more than
:data:`MIN_GAIN`, with the widths along
the ``directions`` widest directions left (the eigenvectors V of Qᵀ C Q with the largest
variance) before (√(v_iᵀ C v_i)) and after (√(v_iᵀ C_a v_i)), and the parameters whose marginal
width √diag C_a it narrows most. The design is local: it holds where E is close to quadratic over
the widths it reports, as the Laplace widths do.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from belief.errors import BeliefError
from belief.identifiability import MASS_FORCE, direction_text
from belief.result import IdentificationResult, floor_set
from physics.fixed import FixedParameters
from physics.measurements import MeasurementPrior
from physics.objective import Objective
from physics.scaling import mass_exponents

if TYPE_CHECKING:               # the simulator loads only when a design runs (tests/physics/test_imports.py)
    from physics.candidate_recordings import FlopMotion
    from physics.trajectory_objective import TrajectoryObjective

__all__ = ["DesignConfig", "DEFAULT_DESIGN", "MIN_GAIN", "SIMULATION_COST", "MotionScore", "RecordingSuggestion",
           "jacobian_along", "information_now", "suggest_recording", "next_recording", "expected_seconds"]


@dataclass(frozen=True)
class DesignConfig:
    """changes, n_cables: the candidate flops' relative rest-length changes and cable counts (crossed
    with the resting face's three edges); directions: how many of the widest directions are reported;
    step: the finite-difference step in relative change (0.2 %: the Gauss-Newton step's 1 % of a
    ±10 % box); duration [s] of each candidate, None for the first recording's."""

    changes: tuple[float, ...] = (0.18, 0.3, 0.45)
    n_cables: tuple[int, ...] = (4,)
    directions: int = 4
    step: float = 0.002
    duration: float | None = None

    def __post_init__(self) -> None:
        if not self.changes or not self.n_cables:
            raise BeliefError("DesignConfig needs at least one change and one cable count, e.g. changes=(0.3,).")
        if isinstance(self.directions, bool) or not isinstance(self.directions, int) or self.directions < 1:
            raise BeliefError(f"DesignConfig.directions must be an integer >= 1, got {self.directions!r}.")
        if not (np.isfinite(self.step) and 0 < self.step <= 0.1):
            raise BeliefError(f"DesignConfig.step must be a relative change in (0, 0.1], got {self.step!r}.")
        if self.duration is not None and not (np.isfinite(self.duration) and self.duration > 0):
            raise BeliefError(f"DesignConfig.duration must be > 0 s or None, got {self.duration!r}.")

    @property
    def candidates(self) -> int:
        """How many candidate flops: the resting face's three edges x changes x cable counts."""
        return 3 * len(self.changes) * len(self.n_cables)


#: a candidate simulation (settling, the flop controller's trial runs, the flop) costs about this many
#: one-step evaluations of a recording of the same length
SIMULATION_COST = 6.0

#: a motion expected to bring at most this [nats] is not suggested
MIN_GAIN = 0.05

#: the default design (frozen, one instance serves as every default argument)
DEFAULT_DESIGN = DesignConfig()


@dataclass(frozen=True)
class MotionScore:
    """A candidate ``motion``, its expected information ``gain`` [nats], the widths along the widest
    directions after it (``after_pct``, k, 1 σ in %) and the marginal widths after it (``marginal_pct``, D)."""

    motion: FlopMotion
    gain: float
    after_pct: tuple[float, ...]
    marginal_pct: tuple[float, ...]


@dataclass(frozen=True)
class RecordingSuggestion:
    """The design (module docstring): parameter ``names``, the widest ``directions`` (text of their
    largest loadings) with their widths ``before_pct`` (1 σ, %), the marginal widths now
    (``marginal_pct``), every candidate's score from best to worst, and ``notes`` (the scale, the
    symmetry left out)."""

    names: tuple[str, ...]
    directions: tuple[str, ...]
    before_pct: tuple[float, ...]
    marginal_pct: tuple[float, ...]
    scores: tuple[MotionScore, ...]
    notes: tuple[str, ...]

    @property
    def best(self) -> MotionScore:
        """The suggested motion's score."""
        return self.scores[0]

    def lines(self) -> list[str]:
        """The section "What to record next" of a summary, one line each."""
        b = self.best
        runner_up = f"; next best {self.scores[1].gain:.2f}" if len(self.scores) > 1 else ""
        out = [f"What to record next ({len(self.scores)} candidate flops from the resting face, simulated at the best "
               "θ; 1-σ widths under this run's likelihood):",
               f"  record {b.motion.label} (expected information {b.gain:.2f} nats{runner_up})"
               if b.gain > MIN_GAIN else f"  no candidate flop is expected to narrow P: the best, {b.motion.label}, "
               f"brings {b.gain:.2f} nats",
               "  the widest directions left, now -> after it:"]
        for text, before, after in zip(self.directions, self.before_pct, b.after_pct, strict=True):
            out.append(f"    {_pct(before):>8s} -> {_pct(after):>8s}  along {text}")
        if all(a > 0.9 * w for a, w in zip(b.after_pct, self.before_pct, strict=True)):
            out.append("  no candidate flop narrows these much: they need another kind of motion or a measurement "
                       "(--measured NAME=VALUE+-SD).")
        narrowed = np.argsort(np.asarray(b.marginal_pct) / np.asarray(self.marginal_pct))[:3]
        out.append("  parameters it narrows most: " + ", ".join(
            f"{self.names[j]} {_pct(self.marginal_pct[j])} -> {_pct(b.marginal_pct[j])}" for j in narrowed))
        return out + [f"  {n}" for n in self.notes]

    def as_dict(self) -> dict[str, object]:
        """JSON-able record with the summary's ``lines``; ``motion`` has the fields of ``planners.FlopAction``
        (``tensegrid probe --next``)."""
        return {"motion": self.best.motion.as_dict(), "label": self.best.motion.label, "lines": self.lines(),
                "names": list(self.names),
                "directions": list(self.directions), "before_pct": list(self.before_pct),
                "marginal_pct": list(self.marginal_pct), "notes": list(self.notes),
                "candidates": [{"motion": s.motion.as_dict(), "label": s.motion.label, "gain": s.gain,
                                "after_pct": list(s.after_pct), "marginal_pct": list(s.marginal_pct)}
                               for s in self.scores]}


def _pct(value: float) -> str:
    """A 1-σ width in % as "±1.2 %"."""
    return f"±{value:.2g} %" if value < 10 else f"±{value:.0f} %"


def _scale(theta: np.ndarray, width: np.ndarray) -> np.ndarray:
    """s_j (D,): |θ̂_j|, or the box's width for a parameter at 0."""
    return np.where(theta != 0.0, np.abs(theta), width)


def _flat(residuals: Sequence[np.ndarray]) -> list[np.ndarray]:
    return [np.nan_to_num(np.ravel(np.asarray(r, float)), nan=0.0) for r in residuals]


def jacobian_along(objective: Objective, theta: np.ndarray, vectors: np.ndarray, step: float) -> list[np.ndarray]:
    """Per segment, the residuals' Jacobian along the columns of ``vectors`` (D x m, relative changes):
    (K_s x m) arrays, forward differences θ̂ + h s ⊙ v (h = ±``step``, the sign that stays in the box),
    one batch of m + 1 evaluations; a failed shifted evaluation gives a zero column (no information).
    Raises :class:`BeliefError` when the evaluation at θ̂ fails."""
    space = objective.space
    width = space.upper - space.lower
    s = _scale(theta, width)
    rows, signs = [theta], []
    for v in np.asarray(vectors, float).T:
        forward = theta + step * s * v
        inside = np.all((forward >= space.lower) & (forward <= space.upper))
        signs.append(1.0 if inside else -1.0)
        rows.append(theta + signs[-1] * step * s * v)
    results = objective.residuals_batch(np.asarray(rows))
    if results[0] is None:
        raise BeliefError("the design's Jacobian cannot start: the simulation at the best θ failed.")
    base = _flat(results[0])
    columns = [[np.zeros_like(b) for b in base] if res is None else
               [(r - b) / (sign * step) for r, b in zip(_flat(res), base, strict=True)]
               for res, sign in zip(results[1:], signs, strict=True)]
    return [np.stack([col[k] for col in columns], axis=1) for k in range(len(base))]


def information_now(objective: Objective, theta: np.ndarray, noise_var: float, *,
                    measurements: MeasurementPrior | None = None, step: float = DEFAULT_DESIGN.step
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(F_data, F_m), each D x D in relative changes at θ̂ (module docstring)."""
    D = objective.space.dim
    J = np.concatenate(jacobian_along(objective, theta, np.eye(D), step), axis=0)
    F_m = np.zeros((D, D))
    if measurements is not None and measurements.measurements:
        width = objective.space.upper - objective.space.lower
        G = measurements.jacobian(theta) * (_scale(theta, width) / width)[None, :]
        F_m = G.T @ G
    return J.T @ J / float(noise_var), F_m


def _complement(theta: np.ndarray, objective: Objective, measured: bool) -> tuple[np.ndarray, tuple[str, ...]]:
    """(Q, D x D' orthonormal: the directions a motion can narrow, notes): without a measurement, all
    but the mass–force scale, which the model's laws leave unseen by any motion (physics.scaling:
    a finite-difference Jacobian shows it only as rounding); all D when something was measured."""
    p = mass_exponents(objective.space) * np.sign(theta)
    if not np.any(p) or measured:
        return np.eye(theta.size), ()
    p_hat = p / np.linalg.norm(p)
    basis = np.linalg.svd(np.eye(theta.size) - np.outer(p_hat, p_hat))[0][:, :theta.size - 1]
    return basis, (f"{MASS_FORCE} is left out: no motion narrows it; a weighed rod does "
                   "(--measured rod_mass=KG+-SD).",)


def _widest(C: np.ndarray, Q: np.ndarray, k: int) -> np.ndarray:
    """V (D x k): the k directions in the span of Q along which C is widest, largest loading positive."""
    values, vectors = np.linalg.eigh(Q.T @ C @ Q)
    V = Q @ vectors[:, np.argsort(values)[::-1][:min(k, Q.shape[1])]]
    return V * np.where(V[np.abs(V).argmax(axis=0), np.arange(V.shape[1])] >= 0, 1.0, -1.0)


def _percent(cov: np.ndarray) -> tuple[float, ...]:
    """1-σ widths in % from a covariance in relative changes."""
    return tuple(float(x) for x in 100.0 * np.sqrt(np.clip(np.diag(cov), 0.0, None)))


def _logdet(A: np.ndarray) -> float:
    return float(np.linalg.slogdet(0.5 * (A + A.T))[1])


def suggest_recording(objective: Objective, theta: np.ndarray, candidates: Objective, motions: Sequence[FlopMotion],
                      *, noise_var: float, floor_scaled: bool, measurements: MeasurementPrior | None = None,
                      information: np.ndarray | None = None, config: DesignConfig = DEFAULT_DESIGN
                      ) -> RecordingSuggestion:
    """The design of the module docstring at θ̂ = ``theta`` (D, ``objective``'s space): ``candidates``
    an objective with one segment per motion in ``motions`` (physics.candidate_recordings), in the
    same space; ``noise_var`` σ² per residual; ``floor_scaled``: σ² was set by the model-error floor
    (belief.result.floor_set); ``information``: F_x of the data and measurements when the run has
    it (the local stage's map), else it is measured here. Raises :class:`BeliefError` for a mismatch."""
    theta = np.asarray(theta, float)
    if len(candidates.segments) != len(motions) or not motions or candidates.space.names != objective.space.names:
        raise BeliefError(f"the candidates' objective needs one segment per motion ({len(motions)}, got "
                          f"{len(candidates.segments)}) in the data objective's space.")
    if not (np.isfinite(noise_var) and noise_var > 0):
        raise BeliefError(f"noise_var must be a residual variance σ² > 0, got {noise_var!r}.")
    width = objective.space.upper - objective.space.lower
    if information is None:
        F_data, F_m = information_now(objective, theta, noise_var, measurements=measurements, step=config.step)
    else:
        F_data, F_m = np.asarray(information, float), np.zeros_like(information)
    box = np.diag(12.0 * (_scale(theta, width) / width) ** 2)
    C = np.linalg.inv(F_data + F_m + box)
    Q, notes = _complement(theta, objective, measurements is not None and bool(measurements.measurements))
    V = _widest(C, Q, config.directions)
    K, now, scores = objective.n_observations, _logdet(Q.T @ C @ Q), []
    for motion, G in zip(motions, jacobian_along(candidates, theta, np.eye(theta.size), config.step), strict=True):
        c = K / (K + G.shape[0]) if floor_scaled else 1.0
        C_a = np.linalg.inv(c * (F_data + G.T @ G / noise_var) + F_m + box)
        scores.append(MotionScore(motion, 0.5 * (now - _logdet(Q.T @ C_a @ Q)), _percent(V.T @ C_a @ V),
                                  _percent(C_a)))
    if floor_scaled:
        notes += ("σ² is the model-error floor (δ E_min / 2), which grows with the data: a recording narrows P only "
                  "along what it newly moves; with σ² measured from the data (--preset handoff-local) it counts in "
                  "full.",)
    return RecordingSuggestion(
        names=objective.space.names, directions=tuple(direction_text(v, objective.space.names) for v in V.T),
        before_pct=_percent(V.T @ C @ V), marginal_pct=_percent(C),
        scores=tuple(sorted(scores, key=lambda s: -s.gain)), notes=notes)


def next_recording(result: IdentificationResult, objective: Objective, *, known: MeasurementPrior | None = None,
                   config: DesignConfig = DEFAULT_DESIGN) -> RecordingSuggestion:
    """What to record next after ``result``, identified on ``objective`` (a TrajectoryObjective, or one
    with parameters held by ``known``, whose measurements also count): the candidate flops are
    simulated at the best θ like the data's first recording (its duration unless ``config`` gives
    one, 2-10 s) on the objective's workers. Raises :class:`BeliefError` without trajectory data or
    a likelihood σ², PhysicsError when a candidate's simulation diverges."""
    from physics.candidate_recordings import candidate_objective, flop_motions

    belief, data = result.belief, _data(objective)
    if belief is None or belief.attrs.get("noise_var") is None or data is None:
        raise BeliefError("what to record next needs trajectory data (a TrajectoryObjective) and a likelihood "
                          "posterior (its σ²).")
    theta = np.asarray(result.best_theta.values, float)
    full = theta if known is None else known.full(theta)
    times = data.trajectories[0]["time"].values
    duration = config.duration or float(np.clip(times[-1] - times[0], 2.0, 10.0))
    motions = flop_motions(data, full, changes=config.changes, n_cables=config.n_cables, duration=duration)
    with candidate_objective(data, full, motions) as raw:
        pin = result.identifiability
        return suggest_recording(objective, theta, raw if known is None else known.hold(raw), motions,
                                 noise_var=float(belief.attrs["noise_var"]), floor_scaled=floor_set(belief.attrs),
                                 measurements=known if known is not None and known.measurements else None,
                                 information=None if pin is None else pin.information(), config=config)


def _data(objective: Objective) -> TrajectoryObjective | None:
    from physics.trajectory_objective import TrajectoryObjective

    data = objective.objective if isinstance(objective, FixedParameters) else objective
    return data if isinstance(data, TrajectoryObjective) else None


def expected_seconds(result: IdentificationResult, objective: Objective,
                     config: DesignConfig = DEFAULT_DESIGN) -> float | None:
    """Seconds :func:`next_recording` takes, from the run's median evaluation time t over its n
    recordings: (D + 1) evaluations of the data and of the m candidates (t / n each), on the
    objective's workers, and m simulations of :data:`SIMULATION_COST` t / n each; None without
    trajectory data or timed evaluations."""
    data, seconds = _data(objective), np.asarray(result.history["seconds"].values, float)
    if data is None or not np.isfinite(seconds).any():
        return None
    t, m, n = float(np.nanmedian(seconds)), config.candidates, len(data.trajectories)
    return (objective.space.dim + 1) * t * (1 + m / n) / max(data.n_workers, 1) + SIMULATION_COST * m * t / n
