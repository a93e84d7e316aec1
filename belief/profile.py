"""Profile-likelihood intervals at the local fit: how far each parameter can move before the data,
with every other parameter re-fitted, object at the level's threshold.

The Laplace approximation at the fit reads E's curvature at one point. E's valleys curve and
flatten beyond it (contact, saturating cables, the mass–force ridge), so its marginal intervals can
be several times too narrow, and a sharp interval that misses is the worst answer the tool can
give. The profile likelihood (Venzon & Moolgavkar 1988; Raue et al. 2009, "Structural and
practical identifiability analysis ... exploiting the profile likelihood") asks E itself. With
L(θ) = E(θ)/(2σ²) − log p_measured(θ) in nats, the profile of parameter j is
PL_j(c) = min over the others of L(θ | θ_j = c), and its level-α interval is where
PL_j(c) − L_min < ½ χ²₁(α) (1.35 nats at α = 0.9).

Each profile point is found by the chord method, in the unit box u: start at the Laplace
approximation's conditional optimum û + t d_j (d_j = Σ e_j / Σ_jj, Σ the local covariance; from
the side's last profile point on, so that the walk follows a valley that curves), then
``chords`` Gauss-Newton steps of the other parameters with the residuals at the point and the fit's
Jacobian J, updated along each side's walk by Broyden's secant rule from every point it evaluated
(each step one evaluation; the point is kept where L fell). A side starts at the
Laplace half-width t₀ = z_α Σ_jj^½; while its rise stays under the threshold it moves out, for
at most ``rounds`` rounds or to the box's face. Each move extrapolates the rise's growth
rise ∝ t^p between the side's last two points to the threshold (p = 2 at first), by at most
``reach`` times, and by ``reach`` where E levels off (p ≤ ½). The half-width is where the rise
crosses the threshold (linear in √rise between the last two points), the distance to the face
when it never does. Every parameter's probes of a round run as one batch per chord. The profile
can only widen: ``stretch`` s_j = max(1, widest side / t₀).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import lsq_linear
from scipy.stats import chi2, norm

from belief.errors import BeliefError
from physics.measurements import MeasurementPrior
from physics.objective import Objective

__all__ = ["ProfileConfig", "DEFAULT_PROFILE", "Profiles", "profile_widths"]


@dataclass(frozen=True)
class ProfileConfig:
    """chords: Gauss-Newton steps of the other parameters per profile point; rounds: outward moves
    per side at most; reach: the largest factor of one outward move; narrow: profile only the
    parameters whose Laplace interval is under this share of the box (the rest already span it)."""

    chords: int = 2
    rounds: int = 3
    reach: float = 4.0
    narrow: float = 0.5

    def __post_init__(self) -> None:
        for name, value in {"chords": self.chords, "rounds": self.rounds}.items():
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
                raise BeliefError(f"ProfileConfig.{name} must be an integer >= 0, got {value!r}.")
        if not (np.isfinite(self.reach) and self.reach > 1) or not (0 < self.narrow <= 1):
            raise BeliefError(f"ProfileConfig needs reach > 1 and 0 < narrow <= 1, got {self.reach!r}, "
                              f"{self.narrow!r}.")


#: the default profile check (frozen, so one instance serves as every default argument)
DEFAULT_PROFILE = ProfileConfig()


@dataclass(frozen=True)
class Profiles:
    """stretch (D,) ≥ 1: each parameter's profile half-width over its Laplace half-width (1 where not
    profiled); half (D, 2): the half-widths below and above the centre in the unit box (NaN where not
    profiled); evaluations spent; best_unit (D,) and best_nats: the lowest point seen (the centre
    unless a probe fell below it)."""

    stretch: np.ndarray
    half: np.ndarray
    evaluations: int
    best_unit: np.ndarray
    best_nats: float

    def as_dict(self) -> dict[str, object]:
        return {"stretch": [float(v) for v in self.stretch], "evaluations": self.evaluations,
                "best_nats": self.best_nats,
                "half": [[None if not np.isfinite(v) else float(v) for v in row] for row in self.half]}


class _Nats:
    """L(u) = E/(2σ²) − log p_measured in nats, with the flat residuals, from one batch of points."""

    def __init__(self, objective: Objective, noise_var: float, prior: MeasurementPrior | None) -> None:
        self.objective, self.noise_var, self.prior = objective, float(noise_var), prior
        space = objective.space
        self.lower, self.width = space.lower, space.upper - space.lower
        self.evaluations = 0

    def theta(self, u: np.ndarray) -> np.ndarray:
        return self.lower + self.width * np.clip(u, 0.0, 1.0)

    def __call__(self, us: np.ndarray) -> tuple[np.ndarray, list[np.ndarray | None]]:
        """(L (n,), flat residuals or None) at the rows of ``us`` (n, D); L = inf where a run failed."""
        if len(us) == 0:
            return np.zeros(0), []
        thetas = self.theta(np.asarray(us, dtype=float))
        batch = self.objective.residuals_batch(thetas)
        self.evaluations += len(us)
        flat = [None if res is None else np.nan_to_num(np.concatenate([np.ravel(r) for r in res])) for res in batch]
        nats = np.array([np.inf if r is None else float(r @ r) / (2 * self.noise_var) for r in flat])
        if self.prior is not None and self.prior.measurements:
            nats = nats - self.prior.log_density(thetas)
        return nats, flat

    def chord(self, u: np.ndarray, j: int, r: np.ndarray, J: np.ndarray) -> np.ndarray:
        """One Gauss-Newton step of every parameter but j from u, with J fixed: argmin ‖r/σ + J_{−j} δ/σ‖²
        + ‖r_m + G_{−j} δ‖² within the box."""
        keep = np.arange(u.size) != j
        A, b = J[:, keep] / np.sqrt(self.noise_var), -r / np.sqrt(self.noise_var)
        if self.prior is not None and self.prior.measurements:
            theta = self.theta(u)
            G = self.prior.jacobian(theta)[:, keep]
            A, b = np.vstack([A, G]), np.concatenate([b, -self.prior.residuals(theta[None])[0]])
        lower, upper = -u[keep], 1.0 - u[keep]
        step = lsq_linear(A, b, bounds=(lower, upper + 1e-15)).x
        out = u.copy()
        out[keep] = np.clip(u[keep] + step, 0.0, 1.0)
        return out


#: a rise within 2 % of the threshold settles the side (the quadratic's own rise at t₀ is the threshold)
_SETTLED = 0.98


@dataclass
class _Side:
    """One side of one parameter's profile: j, sign, the distance t now, the face's distance, and the
    (t, rise) pairs seen."""

    j: int
    sign: int
    t: float
    face: float
    seen: list[tuple[float, float]]
    half: float | None = None
    point: np.ndarray | None = None
    jacobian: np.ndarray | None = None
    last: tuple[np.ndarray, np.ndarray] | None = None

    def learn(self, u: np.ndarray, r: np.ndarray | None, jacobian: np.ndarray) -> None:
        """Broyden's rank-one update of this side's Jacobian (the fit's at first) by the secant from its
        last evaluated point to (u, r): J += (Δr − J Δu) Δuᵀ / ‖Δu‖², so that the chords further out
        use what the walk has seen of E's curvature."""
        if r is None:
            return
        if self.last is not None:
            du = u - self.last[0]
            norm = float(du @ du)
            if norm > 1e-20:
                if self.jacobian is None:
                    self.jacobian = jacobian.copy()
                self.jacobian += np.outer(r - self.last[1] - self.jacobian @ du, du / norm)
        self.last = (u.copy(), r)

    def start(self, centre: np.ndarray, cov: np.ndarray) -> np.ndarray:
        """The next profile point's start: the last profile point (the centre at first) moved on along
        the conditional direction d_j = Σ e_j / Σ_jj to θ_j = centre_j ± t."""
        base = centre if self.point is None else self.point
        u = np.clip(base + (centre[self.j] + self.sign * self.t - base[self.j]) * cov[:, self.j] / cov[self.j, self.j],
                    0.0, 1.0)
        u[self.j] = np.clip(centre[self.j] + self.sign * self.t, 0.0, 1.0)
        return u


def _crossing(seen: list[tuple[float, float]], threshold: float) -> float:
    """Where the rise crosses ``threshold``, linear in √rise between the last point under it (or the
    centre) and the first over it."""
    t_hi, r_hi = seen[-1]
    t_lo, r_lo = next(((t, r) for t, r in reversed(seen[:-1]) if r < threshold), (0.0, 0.0))
    a, b = np.sqrt(max(r_lo, 0.0)), np.sqrt(r_hi)
    return float(t_lo + (t_hi - t_lo) * (np.sqrt(threshold) - a) / max(b - a, 1e-12))


def _outward(seen: list[tuple[float, float]], threshold: float, reach: float) -> float:
    """How far to move out: the rise's growth rise ∝ t^p between the last two points (p = 2, a
    quadratic, from the first), extrapolated to the threshold; at most ``reach``, and ``reach`` where
    the rise grows slower than √t (E levels off)."""
    t, rise = seen[-1]
    if rise <= 0:
        return reach
    power = 2.0
    if len(seen) > 1 and seen[-2][1] > 0 and t > 1.05 * seen[-2][0]:
        power = float(np.log(rise / seen[-2][1]) / np.log(t / seen[-2][0]))
    if power <= 0.5:
        return reach
    return float(np.clip((threshold / rise) ** (1.0 / power), 1.1, reach))


def _advance(side: _Side, rise: float, threshold: float, reach: float, last: bool) -> None:
    """Record the rise at side.t and either settle the side's half-width or move it outwards."""
    side.seen.append((side.t, rise))
    if not np.isfinite(rise) or rise >= _SETTLED * threshold:
        side.half = side.t if not np.isfinite(rise) else _crossing(side.seen, threshold)
        return
    factor = _outward(side.seen, threshold, reach)
    if side.t >= side.face - 1e-12:
        side.half = side.face
    elif last:
        side.half = min(side.t * factor, side.face)
    else:
        side.t = min(side.t * factor, side.face)


def _probe(nats: _Nats, sides: list[_Side], centre: np.ndarray, cov: np.ndarray, jacobian: np.ndarray,
           chords: int) -> tuple[np.ndarray, np.ndarray]:
    """(L (n,), points (n, D)) of the sides' profile points: conditional optimum, then the chords."""
    us = np.array([s.start(centre, cov) for s in sides])
    values, flat = nats(us)
    for s, u, r in zip(sides, us, flat, strict=True):
        s.learn(u, r, jacobian)
    for _ in range(chords):
        moved = np.array([us[k] if r is None else nats.chord(us[k], s.j, r, jacobian if s.jacobian is None
                                                              else s.jacobian)
                          for k, (s, r) in enumerate(zip(sides, flat, strict=True))])
        new_values, new_flat = nats(moved)
        for s, u, r in zip(sides, moved, new_flat, strict=True):
            s.learn(u, r, jacobian)
        better = new_values < values
        us[better], values = moved[better], np.where(better, new_values, values)
        flat = [nf if b else f for f, nf, b in zip(flat, new_flat, better, strict=True)]
    return values, us


def profile_widths(objective: Objective, centre: np.ndarray, jacobian: np.ndarray, cov: np.ndarray,
                   noise_var: float, *, level: float = 0.9, prior: MeasurementPrior | None = None,
                   config: ProfileConfig = DEFAULT_PROFILE) -> Profiles:
    """The module docstring's profiles at ``centre`` û (D,, unit box), with the fit's J (K x D, unit box),
    the local covariance Σ (D x D, unit box) and σ²; ``prior``: what the user measured."""
    nats = _Nats(objective, noise_var, prior)
    centre = np.clip(np.asarray(centre, dtype=float), 0.0, 1.0)
    J = np.nan_to_num(np.asarray(jacobian, dtype=float))
    base, base_flat = nats(centre[None])
    if not np.isfinite(base[0]):
        raise BeliefError("the profile cannot start: the simulation at the local fit's centre failed.")
    threshold = 0.5 * float(chi2.ppf(level, 1))
    t0 = float(norm.ppf(0.5 + level / 2)) * np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    sides = [_Side(int(j), sign, min(t0[j], face), face, [])
             for j in np.flatnonzero(2 * t0 < config.narrow)
             for sign, face in ((-1, centre[j]), (1, 1.0 - centre[j])) if face > 1e-9]
    for s in sides:
        s.last = (centre, base_flat[0]) if base_flat[0] is not None else None
    best_unit, best_nats = centre.copy(), float(base[0])
    for round_ in range(config.rounds + 1):
        active = [s for s in sides if s.half is None]
        if not active:
            break
        values, points = _probe(nats, active, centre, cov, J, config.chords)
        for s, value, point in zip(active, values, points, strict=True):
            s.point = point
            _advance(s, value - base[0], threshold, config.reach, last=round_ == config.rounds)
        if values.size and values.min() < best_nats:
            best_nats, best_unit = float(values.min()), points[int(np.argmin(values))].copy()
    half = np.full((centre.size, 2), np.nan)
    for s in sides:
        half[s.j, int(s.sign > 0)] = s.half
    widest = np.fmax(half[:, 0], half[:, 1])
    stretch = np.where(np.isfinite(widest), np.maximum(1.0, widest / t0), 1.0)
    return Profiles(stretch, half, nats.evaluations, best_unit, best_nats)
