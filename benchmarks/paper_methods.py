"""The methods compared by benchmarks/paper.py, each run on the same recorded objective.

Every method gets an :class:`Recorder` around the fitting objective E(θ), which logs each
evaluation (θ, E, seconds since the method started) whatever way the method calls it, so all
methods are scored the same way: best-so-far θ after n evaluations or t seconds.

* the belief methods are presets of belief.presets (benchmarks/paper.py ``PRESET_OF``):
  ``random-15``, ``bo-15`` (``random``, ``bo``: the Identity decoder on Sobol candidates),
  ``bo-gn`` (``bo``, then one Gauss-Newton step), ``rembo-5``, ``vae-5``, ``ae-dyn-5``,
  ``ae-dyn-prior-5``, ``active-5``, ``ae-cf-5`` (``latent``: BO on a grid over the decoder's 5-D
  box), ``ae-cf-bo`` (``handoff``: BO in ae-cf-5's latent grid, then in the full space with those
  evaluations) and ``ae-cf-bo-gn`` (``handoff-gn``, the library's default: ``ae-cf-bo`` up to
  ``budget`` - (D + 4) evaluations, then one damped Gauss-Newton step over all D parameters from
  its best θ: a Jacobian by forward differences and three step lengths, D + 4 evaluations,
  counted). The 4096 candidates in 15-D are coarse (the nearest to a point of the box is about
  0.18 of the width away per coordinate); the step leaves them. A budget below a preset's
  ``belief.presets.minimum_budget`` is raised to it.
* ``cma-es``: the ``cma`` package in the unit cube (x0 = centre, σ0 = 0.3, default population).
* ``botorch``: a SingleTaskGP on -log E with qLogEI (q = 1), Sobol initial design of the same
  size as identify's, acquisition optimized by L-BFGS-B restarts (optimize_acqf). Torch runs on
  one thread, as belief.identify's GP does: on this 2-core machine, with a simulation running
  beside it, two threads made one GP fit 15 times slower.
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

PEERS = ("cma-es", "botorch")


class Recorder:
    """The objective contract, delegated to ``inner``, logging every evaluation in ``log``.

    Residual evaluations (``residuals``, ``residuals_batch``) are logged only while ``count_residuals`` is set:
    belief methods spend them on the local refit verdict rule after their search (the verdict's cost, not the
    search's, and the same for every belief method), ``ae-cf-bo-gn`` on its counted step.
    """

    def __init__(self, inner: Any) -> None:
        self.inner, self.log, self.start = inner, [], time.perf_counter()
        self.count_residuals = False

    def _note(self, theta: np.ndarray, error: float) -> None:
        self.log.append((np.array(theta, dtype=float), float(error), time.perf_counter() - self.start))

    def __call__(self, theta: np.ndarray) -> float:
        try:
            error = float(self.inner(theta))
        except Exception:
            self._note(theta, np.nan)
            raise
        self._note(theta, error)
        return error

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        try:
            parts = np.asarray(self.inner.evaluate_parts(theta), dtype=float)
        except Exception:
            self._note(theta, np.nan)
            raise
        self._note(theta, float(parts.sum()))
        return parts

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: Callable[..., None] | None = None) -> Any:
        arr = np.atleast_2d(np.asarray(thetas, dtype=float))

        def relay(k: int, error: float, *rest: Any) -> None:
            self._note(arr[k], error)
            if on_result is not None:
                on_result(k, error, *rest)

        return self.inner.evaluate_batch(arr, on_result=relay)

    def residuals(self, theta: np.ndarray) -> Any:
        out = self.inner.residuals(theta)
        if self.count_residuals:
            self._note(theta, float(sum(np.nansum(np.asarray(r) ** 2) for r in out)))
        return out

    def residuals_batch(self, thetas: np.ndarray) -> Any:
        arr = np.atleast_2d(np.asarray(thetas, dtype=float))
        out = self.inner.residuals_batch(arr)
        if self.count_residuals:
            for theta, res in zip(arr, out):
                self._note(theta, np.nan if res is None else float(sum(np.nansum(np.asarray(r) ** 2) for r in res)))
        return out

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


@dataclass
class Run:
    """What one method produced: the evaluation log and, for belief methods, the identification result."""

    method: str
    log: list[tuple[np.ndarray, float, float]]
    result: Any = None
    extra: dict[str, Any] = field(default_factory=dict)


def run_cma(objective: Recorder, space: Any, *, budget: int, seed: int) -> None:
    """CMA-ES in the unit cube until ``budget`` evaluations; a diverged θ costs 10 x the worst E seen."""
    import cma

    es = cma.CMAEvolutionStrategy([0.5] * space.dim, 0.3, {"bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9})
    worst = 1.0
    while len(objective.log) < budget:
        xs = es.ask()[: budget - len(objective.log)]
        values = []
        for x in xs:
            try:
                value = objective(space.from_unit(np.asarray(x)))
            except Exception:
                value = np.nan
            worst = max(worst, value) if np.isfinite(value) else worst
            values.append(value if np.isfinite(value) else 10 * worst)
        if len(xs) < es.popsize:
            break
        es.tell(xs, values)


def run_botorch(objective: Recorder, space: Any, *, budget: int, seed: int, n_init: int) -> None:
    """SingleTaskGP + qLogEI on -log E in the unit cube (module docstring)."""
    import torch
    from botorch.acquisition.logei import qLogExpectedImprovement
    from botorch.fit import fit_gpytorch_mll
    from botorch.models import SingleTaskGP
    from botorch.models.transforms import Standardize
    from botorch.optim import optimize_acqf
    from gpytorch.mlls import ExactMarginalLogLikelihood
    from scipy.stats import qmc

    torch.manual_seed(seed)
    torch.set_num_threads(1)
    bounds = torch.stack([torch.zeros(space.dim), torch.ones(space.dim)]).double()
    X = list(qmc.Sobol(space.dim, scramble=True, seed=seed).random(n_init))
    Y: list[float] = []

    def evaluate(u: np.ndarray) -> float:
        try:
            return -np.log(max(objective(space.from_unit(u)), 1e-300))
        except Exception:
            return np.nan

    Y = [evaluate(u) for u in X]
    while len(objective.log) < budget:
        ok = np.isfinite(Y)
        train_x = torch.tensor(np.array(X)[ok], dtype=torch.double)
        train_y = torch.tensor(np.array(Y)[ok], dtype=torch.double)[:, None]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            gp = SingleTaskGP(train_x, train_y, outcome_transform=Standardize(m=1))
            fit_gpytorch_mll(ExactMarginalLogLikelihood(gp.likelihood, gp))
            acq = qLogExpectedImprovement(gp, best_f=train_y.max())
            cand, _ = optimize_acqf(acq, bounds=bounds, q=1, num_restarts=4, raw_samples=256)
        u = cand.detach().numpy()[0]
        X.append(u)
        Y.append(evaluate(u))
