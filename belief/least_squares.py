"""Local least-squares refinement of some of θ's parameters on some segments of a sum-of-squares objective.

Minimises E_F(θ) = Σ_{s in F} Σ r_s(θ)² (r the objective's residual vectors, F a mask over its
segments) over the parameters ``indices``, the others held, with scipy's bounded trust-region
reflective method (``scipy.optimize.least_squares(method="trf")``). The variables are the unit
box u = (θ - lower) / (upper - lower), so every parameter has the same scale and the box is
[0, 1]^k. The Jacobian is a forward difference, one batch of k evaluations that the objective
runs in parallel (``residuals_batch``)::

    J[:, j] = (r(u + h e_j) - r(u)) / h          (h = ``step``, backwards at the upper bound)

A coordinate search moves one parameter at a time and so crawls along the ridges where
parameters trade off (cable stiffness against a stiffening law, damping against drag); a
Gauss-Newton step moves along them in one go. The result is the best θ evaluated, so E_F never
rises above the start's. A θ whose simulation diverges gets the residual ``10 r(start)``, which
the trust region then steps away from.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares as scipy_least_squares

from belief.errors import BeliefError
from physics.objective import Objective

__all__ = ["LeastSquaresConfig", "LocalFit", "refine", "StepConfig", "DEFAULT_STEP", "LocalStep", "gauss_newton_step",
           "FitConfig", "DEFAULT_FIT", "gauss_newton_fit"]


@dataclass(frozen=True)
class LeastSquaresConfig:
    """evaluations: most residual evaluations of trial points per run (each Jacobian costs k more,
    in one batch); step: the finite-difference step h in the unit box; tolerance: stop when a step
    lowers E_F by less than this fraction (scipy's ftol); rounds: most runs, each from the best
    point of the last (a fresh trust region); converged: a run that lowered E_F by less than this
    fraction of its start has stalled; patience: no further run after this many stalled runs in a
    row. On an error surface with steps (a command delay acts in whole physics steps) one run can
    stall on a poor first Jacobian and the next, from a fresh trust region, still move far."""

    evaluations: int = 12
    step: float = 0.01
    tolerance: float = 1e-3
    rounds: int = 1
    converged: float = 0.01
    patience: int = 1

    def __post_init__(self) -> None:
        if self.evaluations < 1 or not (0 < self.step < 0.5) or not (0 < self.tolerance < 1):
            raise BeliefError(f"LeastSquaresConfig needs evaluations >= 1, 0 < step < 0.5 and 0 < tolerance < 1, "
                              f"got {self.evaluations}, {self.step}, {self.tolerance}.")
        if self.rounds < 1 or not (0 <= self.converged < 1) or self.patience < 1:
            raise BeliefError(f"LeastSquaresConfig needs rounds >= 1, 0 <= converged < 1 and patience >= 1, got "
                              f"{self.rounds}, {self.converged}, {self.patience}.")

    def record(self) -> dict[str, float | int]:
        """The settings that decide the result, for a journal's fingerprint. One round is the plain run,
        and ``converged`` and ``patience`` act only between rounds: with one round they are left out,
        and ``patience`` 1 (stop at the first stalled run) is left out too."""
        settings = vars(self).copy()
        if self.rounds == 1:
            del settings["rounds"], settings["converged"]
        if self.rounds == 1 or self.patience == 1:
            del settings["patience"]
        return settings


@dataclass(frozen=True)
class LocalFit:
    """theta (D,) the best point evaluated, parts (S,) its per-segment errors Σ r_s², error E_F,
    start_error E_F at the start, evaluations (trial points plus Jacobian rows), residuals (S
    arrays (T_s, m)) at theta."""

    theta: np.ndarray
    parts: np.ndarray
    error: float
    start_error: float
    evaluations: int
    residuals: list[np.ndarray]


def _flat(residuals: Sequence[np.ndarray], mask: np.ndarray) -> np.ndarray:
    """The residuals of the masked segments as one vector, NaN (not compared) as 0."""
    return np.nan_to_num(np.concatenate([np.ravel(r) for r, m in zip(residuals, mask, strict=True) if m]), nan=0.0)


class _Problem:
    """r(u) and J(u) of the masked segments for scipy, each θ evaluated once (cached; ``known``: the
    residuals at θ itself when the caller has them)."""

    def __init__(self, objective: Objective, theta: np.ndarray, indices: list[int], mask: np.ndarray,
                 step: float, known: Sequence[np.ndarray] | None = None) -> None:
        self.objective, self.theta, self.indices, self.mask, self.step = objective, theta, indices, mask, step
        self.lower = objective.space.lower[indices]
        self.width = objective.space.upper[indices] - self.lower
        self.cache: dict[bytes, list[np.ndarray] | None] = {}
        if known is not None:           # the caller's residuals at θ: no evaluation repeats them
            self.cache[np.asarray(self.unit(theta[indices]), float).tobytes()] = [np.asarray(r, float) for r in known]
        self.evaluations = 0
        start = self.full(self.unit(theta[indices]))
        if start is None:
            raise BeliefError("least-squares refinement cannot start: the simulation at the starting θ diverged "
                              "or failed.")
        self.penalty = 10.0 * _flat(start, mask) + 1e-12

    def unit(self, values: np.ndarray) -> np.ndarray:
        return (np.asarray(values, float) - self.lower) / self.width

    def thetas(self, us: np.ndarray) -> np.ndarray:
        rows = np.repeat(self.theta[None], len(us), axis=0)
        rows[:, self.indices] = self.lower + self.width * np.clip(us, 0.0, 1.0)
        return rows

    def evaluate(self, us: np.ndarray) -> list[list[np.ndarray] | None]:
        """Residual lists at the rows of ``us`` (n, k), evaluating only those not seen before."""
        keys = [np.asarray(u, float).tobytes() for u in us]
        new = [k for k, key in enumerate(keys) if key not in self.cache]
        if new:
            results = self.objective.residuals_batch(self.thetas(us[new]))
            self.evaluations += len(new)
            for k, res in zip(new, results, strict=True):
                self.cache[keys[k]] = res
        return [self.cache[key] for key in keys]

    def full(self, u: np.ndarray) -> list[np.ndarray] | None:
        return self.evaluate(np.asarray(u, float)[None])[0]

    def fun(self, u: np.ndarray) -> np.ndarray:
        res = self.full(u)
        return self.penalty if res is None else _flat(res, self.mask)

    def jac(self, u: np.ndarray) -> np.ndarray:
        r0 = self.fun(u)
        steps = np.where(u + self.step <= 1.0, self.step, -self.step)
        shifted = np.repeat(np.asarray(u, float)[None], len(u), axis=0) + np.diag(steps)
        columns = [np.zeros_like(r0) if res is None else (_flat(res, self.mask) - r0) / h
                   for res, h in zip(self.evaluate(shifted), steps, strict=True)]
        return np.stack(columns, axis=1)

    def best(self) -> tuple[np.ndarray, list[np.ndarray]]:
        """The evaluated point (unit box) with the lowest E_F and its residuals."""
        scored = [(float((_flat(r, self.mask) ** 2).sum()), key, r) for key, r in self.cache.items() if r is not None]
        _, key, res = min(scored, key=lambda t: t[0])
        return np.frombuffer(key, dtype=float), res


def refine(objective: Objective, theta: np.ndarray, indices: Sequence[int], mask: np.ndarray | Sequence[bool],
           config: LeastSquaresConfig = LeastSquaresConfig()) -> LocalFit:
    """Refine θ[indices] (θ (D,)) on the segments ``mask`` (S,) by bounded least squares (module
    docstring) from the objective's ``residuals_batch``: up to ``config.rounds`` runs, the next
    unless the last ``config.patience`` runs each lowered E_F by at most ``config.converged`` of
    their start. Raises BeliefError if the simulation at θ itself fails, NoResidualsError if the
    objective has no residuals."""
    theta = np.asarray(theta, float).copy()
    mask = np.asarray(mask, bool)
    index = [int(j) for j in indices]
    if mask.shape != (len(objective.segments),) or not mask.any():
        raise BeliefError(f"mask must be a non-empty boolean mask over the {len(objective.segments)} segments.")
    if not index:
        raise BeliefError("refine needs at least one parameter index.")
    problem = _Problem(objective, theta, index, mask, config.step)
    u = np.clip(problem.unit(theta[index]), 0.0, 1.0)
    start_error = error = float((problem.fun(u) ** 2).sum())
    stalled = 0
    for _ in range(config.rounds):
        scipy_least_squares(problem.fun, u, jac=problem.jac, bounds=(0.0, 1.0), method="trf", x_scale=1.0,
                            ftol=config.tolerance, xtol=1e-4, gtol=1e-8, max_nfev=config.evaluations)
        u, residuals = problem.best()
        last, error = error, float((problem.fun(u) ** 2).sum())
        stalled = stalled + 1 if last - error <= config.converged * last else 0
        if stalled >= config.patience:
            break
    theta[index] = problem.thetas(u[None])[0, index]
    parts = np.array([np.nansum(np.asarray(r) ** 2) for r in residuals])
    return LocalFit(theta, parts, float(parts[mask].sum()), start_error, problem.evaluations, residuals)



@dataclass(frozen=True)
class StepConfig:
    """One damped Gauss-Newton step of all D parameters: trust radius (unit box) of the step,
    the step lengths tried (one batch), the finite-difference step h, the ridge λ relative to
    mean diag(JᵀJ)."""

    radius: float = 0.25
    lengths: tuple[float, ...] = (1.0, 0.5, 0.25)
    step: float = 0.01
    ridge: float = 1e-6

    def __post_init__(self) -> None:
        if not (0 < self.radius <= 1) or not self.lengths or not all(0 < a <= 1 for a in self.lengths) \
                or not (0 < self.step < 0.5) or not (self.ridge >= 0):
            raise BeliefError(f"StepConfig needs 0 < radius <= 1, step lengths in (0, 1], 0 < step < 0.5 and "
                              f"ridge >= 0, got {self.radius}, {self.lengths}, {self.step}, {self.ridge}.")

    def cost(self, dim: int) -> int:
        """The evaluations of E one step spends in a D = ``dim`` space: the start, the Jacobian's D and
        one per step length."""
        return dim + 1 + len(self.lengths)


#: the default finishing step (frozen, so one instance serves as every default argument)
DEFAULT_STEP = StepConfig()


@dataclass(frozen=True)
class LocalStep:
    """theta (D,) the best point of the step, error E there, start_error E at the start,
    evaluations spent, jacobian J (K, D) of the residuals in the unit box at the start, width (D,)
    the box widths (θ = lower + width u)."""

    theta: np.ndarray
    error: float
    start_error: float
    evaluations: int
    jacobian: np.ndarray
    width: np.ndarray

    def laplace_std(self, noise_var: float) -> np.ndarray:
        """Local posterior std of θ (D,) over all parameters: sqrt diag (JᵀJ/σ² + τ I)⁻¹ x width.

        JᵀJ/σ² is the Gauss-Newton Hessian of E/(2σ²) in the unit box. τ = 1e-9 x its mean
        diagonal only keeps the inverse finite: a direction the data do not see (a column of J
        that others reproduce, such as m and μ of S = J²/(2 m² μ)) gets a std far beyond the box,
        not the width a prior would lend it.
        """
        F = self.jacobian.T @ self.jacobian / float(noise_var)
        tau = 1e-9 * max(float(np.mean(np.diag(F))), 1e-300)
        cov = np.linalg.inv(F + tau * np.eye(F.shape[0]))
        return np.sqrt(np.clip(np.diag(cov), 0.0, None)) * self.width

    def draw_cov(self, noise_var: float) -> np.ndarray:
        """Covariance (D x D, θ units) for joint draws of the local posterior: (JᵀJ/σ² + 12 I)⁻¹ scaled
        by the widths. 12 I is the precision of the uniform prior over the unit box, so a direction the
        data do not see spreads over the box (its std 1/√12), not far beyond it where no draw lands."""
        F = np.nan_to_num(self.jacobian).T @ np.nan_to_num(self.jacobian) / float(noise_var)
        cov = np.linalg.pinv(F + 12.0 * np.eye(F.shape[0]), hermitian=True)
        return cov * np.outer(self.width, self.width)


def _delta(r: np.ndarray, J: np.ndarray, u: np.ndarray, config: StepConfig) -> np.ndarray:
    """Δ = argmin ||r + JΔ||² + λ||Δ||² within the box and |Δ_j| <= radius (scipy's lsq_linear)."""
    from scipy.optimize import lsq_linear

    lam = config.ridge * max(float(np.mean(np.sum(J * J, axis=0))), 1e-300)
    A = np.vstack([J, np.sqrt(lam) * np.eye(u.size)])
    b = np.concatenate([-r, np.zeros(u.size)])
    lower, upper = np.maximum(-u, -config.radius), np.minimum(1.0 - u, config.radius)
    return lsq_linear(A, b, bounds=(lower, upper + 1e-15)).x


def gauss_newton_step(objective: Objective, theta: np.ndarray, config: StepConfig = StepConfig(), *,
                      start: Sequence[np.ndarray] | None = None) -> LocalStep:
    """One damped Gauss-Newton step from θ (D,) over all parameters and segments.

    With r, J at u (unit box; J by forward differences, one batch of D evaluations), the step is
    Δ = argmin ||r + JΔ||² + λ||Δ||² subject to the box and |Δ_j| <= radius (scipy's lsq_linear);
    the trial points u + aΔ for a in ``lengths`` are evaluated in one more batch. Costs D + 1 +
    len(lengths) evaluations (``config.cost``), one fewer with ``start``, the residuals at θ (S
    arrays) when the caller has evaluated them already. The result's theta is the best point
    evaluated (the start if no trial lowers E); its jacobian is the start's. Raises BeliefError if
    the simulation at θ fails, NoResidualsError if the objective has no residuals (a wrapped plain
    function).
    """
    theta = np.asarray(theta, float).copy()
    problem = _Problem(objective, theta, list(range(theta.size)), np.ones(len(objective.segments), bool), config.step,
                       known=start)
    u = np.clip(problem.unit(theta), 0.0, 1.0)
    r, J = problem.fun(u), problem.jac(u)
    delta = _delta(r, J, u, config)
    problem.evaluate(np.clip(u[None] + np.asarray(config.lengths)[:, None] * delta[None], 0.0, 1.0))
    best_u, residuals = problem.best()
    error = float(sum(np.nansum(np.asarray(res) ** 2) for res in residuals))
    return LocalStep(problem.thetas(best_u[None])[0], error, float((r ** 2).sum()), problem.evaluations, J,
                     problem.width.copy())


@dataclass(frozen=True)
class FitConfig:
    """The local fit that ends an identification: at most ``steps`` damped Gauss-Newton steps
    (each D + 1 + len(lengths) evaluations, ``step`` sets them), stopping once a step lowers E by
    less than ``nats`` nats of the independent-noise likelihood, ``nats`` x 2 E/K (K residuals): a
    relative tolerance would stop short by tens of nats on a long record; the Jacobian at the end
    point costs D more when the last step moved."""

    steps: int = 5
    nats: float = 1.0
    step: StepConfig = StepConfig()

    def __post_init__(self) -> None:
        if isinstance(self.steps, bool) or not isinstance(self.steps, (int, np.integer)) or self.steps < 1 \
                or not (np.isfinite(self.nats) and self.nats > 0):
            raise BeliefError(f"FitConfig needs steps >= 1 and nats > 0, got {self.steps!r}, {self.nats!r}.")

    def cost(self, dim: int) -> int:
        """The most evaluations the fit spends in a D = ``dim`` space."""
        return self.steps * (dim + 1 + len(self.step.lengths)) + dim


#: the default local fit (frozen, so one instance serves as every default argument)
DEFAULT_FIT = FitConfig()


def gauss_newton_fit(objective: Objective, theta: np.ndarray, config: FitConfig = DEFAULT_FIT
                     ) -> tuple[LocalStep, list[np.ndarray]]:
    """Damped Gauss-Newton steps (:func:`gauss_newton_step`'s) from θ (D,) until one lowers E by less
    than ``config.nats`` x 2 E/K, at most ``config.steps``; returns the end point as a LocalStep
    whose jacobian (K x D, unit box) is taken AT the end point (the Laplace approximation's), and
    the residuals there (S arrays). Raises as :func:`gauss_newton_step`."""
    theta = np.asarray(theta, float).copy()
    cfg = config.step
    problem = _Problem(objective, theta, list(range(theta.size)), np.ones(len(objective.segments), bool), cfg.step)
    u = np.clip(problem.unit(theta), 0.0, 1.0)
    start_error = error = float((problem.fun(u) ** 2).sum())
    count = max(int(problem.fun(u).size), 1)
    for _ in range(config.steps):
        delta = _delta(problem.fun(u), problem.jac(u), u, cfg)
        problem.evaluate(np.clip(u[None] + np.asarray(cfg.lengths)[:, None] * delta[None], 0.0, 1.0))
        u_new, _ = problem.best()
        new_error = float((problem.fun(u_new) ** 2).sum())
        moved, gain = not np.array_equal(u_new, u), error - new_error
        u, error = u_new, new_error
        if not moved or gain <= config.nats * 2.0 * error / count:
            break
    J = problem.jac(u)
    residuals = problem.full(u)
    assert residuals is not None
    return (LocalStep(problem.thetas(u[None])[0], error, start_error, problem.evaluations, J, problem.width.copy()),
            residuals)
