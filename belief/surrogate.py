"""Gaussian-process surrogate of the error E(z) on pyro.contrib.gp.

Model (Zhu et al. 2018, Algorithm 1, "fit a GP to the evaluated errors")::

    x = (z - lower) / (upper - lower)                     inputs scaled to the unit cube, n x d
    t = log(E - E_min + c)   (or t = E)                   optional log transform, c > 0
    y = (t - mean(t)) / std(t)                            standardized target, n
    y ~ GP(0, k) + N(0, noise),  k = Matern-5/2 with one lengthscale per latent dimension (ARD)

Hyperparameters (outputscale, lengthscales, noise) are MAP estimates under priors
(``pyro.nn.PyroSample`` with the default Delta autoguide of ``pyro.contrib.gp.Parameterized``),
optimized by L-BFGS (strong Wolfe line search) on ``Trace_ELBO().differentiable_loss``:

- lengthscale_i ~ LogNormal(sqrt(2) + log(d) / 2, sqrt(3))   (dimension-scaled prior of
  Hvarfner, Hellsten & Nardi 2024, "Vanilla Bayesian optimization performs great in high dimensions")
- outputscale ~ LogNormal(0, 1);  noise ~ LogNormal(log 1e-4, 2)   (E is deterministic in z)

The fit starts from fixed initial values (no random restarts), so it is a deterministic function
of the data; data are sorted lexicographically by (z, E) first, which makes the fit, hence every
prediction, exactly invariant to the order of evaluation. If the Cholesky factorization fails, the
jitter is multiplied by 10 up to ``max_jitter``. All torch work runs on ``num_threads`` threads
(default 1), restored afterwards, so results are bit-for-bit reproducible on any machine.

``c`` (log offset) = ``log_offset * median(E - E_min)`` (floored at 1e-12 relative): it keeps the
transform finite at the best point and is scale-equivariant.

Prediction (``predict``, the cost of the acquisition on large grids) factorizes K = L L^T once per
fitted model and evaluates the n x cells cross-covariance in cache-sized chunks with one matrix
product for the distances and one triangular solve; it equals pyro's ``GPRegression.forward`` to
rounding, in float64 (in float32 the variance near the data, a difference of two nearly equal
numbers, loses most of its digits).
"""
from __future__ import annotations

import contextlib
import copy
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pyro
import pyro.contrib.gp as gp
import pyro.distributions as dist
import torch
from pyro.nn import PyroParam, PyroSample
from torch.distributions import constraints

from belief.errors import BeliefError, SurrogateError
from belief.kernel import Matern52, augment, matern52_unit

__all__ = ["SurrogateConfig", "GPSurrogate"]


@dataclass(frozen=True)
class SurrogateConfig:
    """Options of :class:`GPSurrogate` (validated on construction).

    ``log_transform``: fit log(E - E_min + c) instead of E; ``log_offset``: c relative to the
    median excess error; ``max_iter``: L-BFGS iterations; ``jitter``/``max_jitter``: diagonal
    added to K (raised x10 on Cholesky failure); ``noise_init``: initial noise in standardized
    units; ``chunk_size``: cells per prediction chunk (512 keeps the chunk x n work buffers of
    :meth:`GPSurrogate.predict` in cache; the results do not depend on it); ``num_threads``: torch threads;
    ``impute_failed``: give failed evaluations the worst observed error instead of leaving them out
    of the fit (pushes the search away from them).
    """

    log_transform: bool = True
    log_offset: float = 1.0
    max_iter: int = 100
    jitter: float = 1e-8
    max_jitter: float = 1e-2
    noise_init: float = 1e-4
    chunk_size: int = 512
    num_threads: int = 1
    impute_failed: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.impute_failed, bool):
            raise BeliefError(f"SurrogateConfig.impute_failed must be True or False, got {self.impute_failed!r}.")
        if not (np.isfinite(self.log_offset) and self.log_offset > 0):
            raise BeliefError(f"SurrogateConfig.log_offset must be a positive number, got {self.log_offset!r}.")
        if not isinstance(self.max_iter, int) or self.max_iter < 1:
            raise BeliefError(f"SurrogateConfig.max_iter must be an int >= 1, got {self.max_iter!r}.")
        if not (0 < self.jitter <= self.max_jitter):
            raise BeliefError(
                f"SurrogateConfig needs 0 < jitter <= max_jitter, got jitter={self.jitter!r}, "
                f"max_jitter={self.max_jitter!r}."
            )
        if not (self.noise_init > 0):
            raise BeliefError(f"SurrogateConfig.noise_init must be > 0, got {self.noise_init!r}.")
        if not isinstance(self.chunk_size, int) or self.chunk_size < 1:
            raise BeliefError(f"SurrogateConfig.chunk_size must be an int >= 1, got {self.chunk_size!r}.")
        if not isinstance(self.num_threads, int) or self.num_threads < 1:
            raise BeliefError(f"SurrogateConfig.num_threads must be an int >= 1, got {self.num_threads!r}.")


@contextlib.contextmanager
def _torch_context(num_threads: int) -> Iterator[None]:
    """Local pyro parameters (no global param store) and a fixed torch thread count."""
    old = torch.get_num_threads()
    torch.set_num_threads(num_threads)
    try:
        with pyro.settings.context(module_local_params=True), pyro.validation_enabled(False):
            yield
    finally:
        torch.set_num_threads(old)


_DT = torch.float64


@dataclass(frozen=True)
class _PredictionCache:
    """What :meth:`GPSurrogate.predict` reuses for every chunk of one fitted model (``n`` data, ``d`` dims).

    ``model``, ``X``, ``y``: the GPRegression it was built from and its data (valid only while
    ``gp_ is model`` and its data tensors are the same objects);
    ``scale``: sqrt5 / lengthscale (``d``); ``x_aug_t``: augmented scaled data ``(d+2) x n``;
    ``alpha``: s^2 K^-1 (y - mu(X)) (``n``); ``chol_t``: L^T / s^2 (``n x n``, upper), with
    L L^T = K = k(X, X) + (noise + jitter) I as in ``GPRegression.forward``; ``outputscale``: s^2.
    """

    model: gp.models.GPRegression
    X: torch.Tensor
    y: torch.Tensor
    scale: torch.Tensor
    x_aug_t: torch.Tensor
    alpha: torch.Tensor
    chol_t: torch.Tensor
    outputscale: float


class GPSurrogate:
    """GP surrogate of E over a latent box; see the module docstring for the model.

    ``bounds``: latent box ``d x 2``. After :meth:`fit`, fitted attributes: ``gp_`` (the
    ``pyro.contrib.gp.models.GPRegression``), ``shift_`` (E_min - c, or None without log
    transform), ``t_mean_``/``t_std_`` (standardization of t), ``jitter_`` (jitter used),
    ``best_t_`` (smallest observed t), ``n_`` (number of data).
    """

    shift_: float | None
    _pred_cache_: _PredictionCache | None

    def __init__(self, bounds: np.ndarray, *, config: SurrogateConfig | None = None) -> None:
        b = np.asarray(bounds, dtype=float)
        if b.ndim != 2 or b.shape[1] != 2 or np.any(b[:, 0] >= b[:, 1]):
            raise BeliefError(f"GPSurrogate bounds must be a (d, 2) array with lower < upper, got {b.tolist()}.")
        self.bounds = b
        self.config = config or SurrogateConfig()

    # ------------------------------------------------------------------ transforms
    @property
    def dim(self) -> int:
        return int(self.bounds.shape[0])

    def _scale(self, z: np.ndarray) -> torch.Tensor:
        lo, hi = self.bounds[:, 0], self.bounds[:, 1]
        return torch.as_tensor((np.asarray(z, dtype=float) - lo) / (hi - lo), dtype=_DT)

    def transform(self, errors: np.ndarray) -> np.ndarray:
        """t(E): log(E - shift_) with log transform, else E (same shape as ``errors``)."""
        e = np.asarray(errors, dtype=float)
        if self.shift_ is None:
            return e
        return np.log(np.maximum(e - self.shift_, 1e-300))

    def inverse_transform(self, t: np.ndarray) -> np.ndarray:
        """E(t) = exp(t) + shift_ (log transform) or t."""
        t = np.asarray(t, dtype=float)
        return t if self.shift_ is None else np.exp(t) + self.shift_

    # ------------------------------------------------------------------ fitting
    def _build(self, X: torch.Tensor, y: torch.Tensor, jitter: float) -> gp.models.GPRegression:
        d = X.shape[1]
        t = lambda v: torch.as_tensor(v, dtype=_DT)  # noqa: E731
        ls0 = float(np.clip(0.3 * np.sqrt(d), 0.2, 2.0))
        kernel = Matern52(input_dim=d, variance=t(1.0), lengthscale=torch.full((d,), ls0, dtype=_DT))
        # pyro's annotations declare these attributes PyroParam; PyroModule also accepts a PyroSample (a prior)
        kernel.lengthscale = PyroSample(  # type: ignore[assignment]
            dist.LogNormal(t(np.sqrt(2.0) + 0.5 * np.log(d)), t(np.sqrt(3.0))).expand([d]).to_event(1)
        )
        kernel.variance = PyroSample(dist.LogNormal(t(0.0), t(1.0)))  # type: ignore[assignment]
        model = gp.models.GPRegression(X, y, kernel, noise=t(self.config.noise_init), jitter=jitter)
        model.noise = PyroSample(dist.LogNormal(t(np.log(1e-4)), t(2.0)))  # type: ignore[assignment]
        # deterministic initial values (the autoguide would otherwise draw them from the prior)
        kernel.lengthscale_map = PyroParam(torch.full((d,), ls0, dtype=_DT), constraints.positive)
        kernel.variance_map = PyroParam(t(1.0), constraints.positive)
        model.noise_map = PyroParam(t(self.config.noise_init), constraints.positive)
        return model

    def fit(self, z: np.ndarray, errors: np.ndarray) -> GPSurrogate:
        """Fit to latent points ``z`` (``n x d``) and errors ``E`` (``n``, finite); returns self."""
        Z = np.asarray(z, dtype=float)
        E = np.asarray(errors, dtype=float)
        if Z.ndim != 2 or Z.shape[1] != self.dim:
            raise BeliefError(f"GPSurrogate.fit: z must have shape (n, {self.dim}), got {Z.shape}.")
        if E.shape != (Z.shape[0],):
            raise BeliefError(f"GPSurrogate.fit: errors must have shape ({Z.shape[0]},), got {E.shape}.")
        if Z.shape[0] < 2:
            raise BeliefError(f"GPSurrogate.fit needs at least 2 successful evaluations, got {Z.shape[0]}.")
        if not (np.all(np.isfinite(Z)) and np.all(np.isfinite(E))):
            raise BeliefError("GPSurrogate.fit: z and errors must be finite; drop failed evaluations first.")
        order = np.lexsort(np.column_stack([Z, E]).T[::-1])
        Z, E = Z[order], E[order]
        if self.config.log_transform:
            excess = E - E.min()
            c = self.config.log_offset * float(np.median(excess))
            c = max(c, 1e-12 * max(abs(float(E.min())), float(excess.max()), 1e-300))
            self.shift_ = float(E.min()) - c
        else:
            self.shift_ = None
        tt = self.transform(E)
        self.t_mean_ = float(np.mean(tt))
        sd = float(np.std(tt))
        self.t_std_ = sd if sd > 0 else 1.0
        self.best_t_ = float(tt.min())
        self.z_ = Z
        self.errors_ = E
        self.n_ = int(Z.shape[0])
        X = self._scale(Z)
        y = torch.as_tensor((tt - self.t_mean_) / self.t_std_, dtype=_DT)
        jitter = self.config.jitter
        with _torch_context(self.config.num_threads):
            while True:
                try:
                    model = self._build(X, y, jitter)
                    opt = torch.optim.LBFGS(model.parameters(), lr=1.0, max_iter=self.config.max_iter,
                                            line_search_fn="strong_wolfe")
                    gp.util.train(model, opt, pyro.infer.Trace_ELBO().differentiable_loss, num_steps=1)
                    with torch.no_grad():
                        loss = float(pyro.infer.Trace_ELBO().differentiable_loss(model.model, model.guide))
                    if not np.isfinite(loss):
                        raise torch.linalg.LinAlgError("non-finite marginal likelihood")
                    break
                except (torch.linalg.LinAlgError, RuntimeError, ValueError) as exc:
                    jitter *= 10.0
                    if jitter > self.config.max_jitter:
                        raise SurrogateError(
                            f"GP fit failed even with jitter {jitter / 10:.1e} ({exc}); the errors may contain "
                            "duplicates with different values or extreme outliers; raise SurrogateConfig.max_jitter."
                        ) from exc
        model.set_mode("guide")
        self.gp_ = model
        self.jitter_ = jitter
        self.loss_ = loss
        return self

    def _check_fitted(self) -> None:
        if not hasattr(self, "gp_"):
            raise BeliefError("GPSurrogate is not fitted; call fit(z, errors) first.")

    @property
    def lengthscale_(self) -> np.ndarray:
        """Fitted ARD lengthscales in unit-cube units, shape ``d``."""
        self._check_fitted()
        with _torch_context(self.config.num_threads), torch.no_grad():
            self.gp_.set_mode("guide")
            return self.gp_.kernel.lengthscale.detach().numpy().copy()

    @property
    def noise_(self) -> float:
        self._check_fitted()
        with _torch_context(self.config.num_threads), torch.no_grad():
            self.gp_.set_mode("guide")
            return float(self.gp_.noise)  # type: ignore[arg-type]  # a Tensor when read; pyro annotates the PyroParam

    # ------------------------------------------------------------------ prediction
    def _prediction_cache(self) -> _PredictionCache:
        """Cholesky factor and weights of the fitted model, computed once per ``gp_`` (not per chunk).

        Same algebra as pyro's ``GPRegression.forward``: K = k(X, X) + (noise + jitter) I = L L^T,
        alpha = K^-1 (y - mu(X)) (mu = the GP's mean function, zero here).
        """
        cache = getattr(self, "_pred_cache_", None)
        if cache is not None and cache.model is self.gp_ and cache.X is self.gp_.X and cache.y is self.gp_.y:
            return cache
        model = self.gp_
        model.set_mode("guide")
        X = model.X
        n = X.shape[0]
        K = model.kernel(X).contiguous()
        K.view(-1)[:: n + 1] += model.jitter + model.noise
        L = torch.linalg.cholesky(K)
        resid = (model.y - model.mean_function(X))[:, None]
        alpha = torch.linalg.solve_triangular(L.T, torch.linalg.solve_triangular(L, resid, upper=False), upper=True)
        s2 = float(model.kernel.variance)
        scale = (5.0**0.5 / model.kernel.lengthscale).detach()
        cache = _PredictionCache(
            model=model,
            X=X,
            y=model.y,
            scale=scale,
            x_aug_t=augment((X - 0.5) * scale, query=False).T.contiguous(),
            alpha=(alpha[:, 0] * s2).contiguous(),
            chol_t=(L.T / s2).contiguous(),
            outputscale=s2,
        )
        self._pred_cache_ = cache
        return cache

    def predict(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and variance of the latent f = t(E) at ``z`` (``m x d``): two arrays of shape ``m``.

        Noiseless predictive (the GP's noise term excluded), in t units (log units with the log
        transform). Equal to pyro's ``gp_(x, full_cov=False, noiseless=True)`` to rounding (~1e-13
        relative, variance ~1e-14 of s^2; tested), but faster: L and alpha are computed once per
        fitted model (:class:`_PredictionCache`), then per chunk of ``config.chunk_size`` query rows
        x (``k x d``)::

            k0   = k(x, X) / s^2                      k x n  (Matern-5/2 via one matmul, no allocation)
            mean = k0 (s^2 alpha) + mu(x)             k
            W    = k0 (L^T / s^2)^-1 = k(x, X) L^-T   k x n  (triangular solve)
            var  = s^2 - rowsum(W^2)                  k,  clamped at 0

        then mean * t_std + t_mean, var * t_std^2. Deterministic (no randomness, fixed thread count).
        """
        self._check_fitted()
        Zq = np.asarray(z, dtype=float)
        if Zq.ndim != 2 or Zq.shape[1] != self.dim:
            raise BeliefError(f"GPSurrogate.predict: z must have shape (m, {self.dim}), got {Zq.shape}.")
        m = Zq.shape[0]
        cs = max(1, min(self.config.chunk_size, m))
        with _torch_context(self.config.num_threads), torch.no_grad():
            c = self._prediction_cache()
            n = c.x_aug_t.shape[1]
            Zs = self._scale(Zq)
            q_aug = augment((Zs - 0.5) * c.scale, query=True)
            mean = torch.empty(m, dtype=_DT)
            quad = torch.empty(m, dtype=_DT)
            d2, sb, eb, wb = (torch.empty(cs, n, dtype=_DT) for _ in range(4))
            for s in range(0, m, cs):
                e = min(s + cs, m)
                k = e - s
                k0 = matern52_unit(q_aug[s:e], c.x_aug_t, d2[:k], sb[:k], eb[:k])
                torch.mv(k0, c.alpha, out=mean[s:e])
                w = torch.linalg.solve_triangular(c.chol_t, k0, upper=True, left=False, out=wb[:k])
                torch.sum(w.mul_(w), 1, out=quad[s:e])
            mean += self.gp_.mean_function(Zs)
            var = (c.outputscale - quad).clamp_(min=0.0)
        return mean.numpy() * self.t_std_ + self.t_mean_, var.numpy() * self.t_std_**2

    def predict_joint(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint posterior of f = t(E) at ``z`` (``m x d``): mean ``m`` and covariance ``m x m`` (t units)."""
        self._check_fitted()
        Zq = np.asarray(z, dtype=float)
        if Zq.ndim != 2 or Zq.shape[1] != self.dim:
            raise BeliefError(f"GPSurrogate.predict_joint: z must have shape (m, {self.dim}), got {Zq.shape}.")
        with _torch_context(self.config.num_threads), torch.no_grad():
            m, c = self.gp_(self._scale(Zq), full_cov=True, noiseless=True)
        return m.numpy() * self.t_std_ + self.t_mean_, c.numpy() * self.t_std_**2

    def fantasize(self, z: np.ndarray, t: np.ndarray) -> GPSurrogate:
        """A copy conditioned on extra pseudo-observations (``k x d``, ``k`` in t units), same hyperparameters.

        Used by the kriging-believer batch (belief.acquisition): no refit, only new data.
        """
        self._check_fitted()
        Zx = np.atleast_2d(np.asarray(z, dtype=float))
        tx = np.atleast_1d(np.asarray(t, dtype=float))
        new = copy.copy(self)
        new._pred_cache_ = None  # built for self.gp_; predict rebuilds it for the new model
        with _torch_context(self.config.num_threads), torch.no_grad():
            model = copy.deepcopy(self.gp_)
            X = torch.cat([model.X, self._scale(Zx)])
            y = torch.cat([model.y, torch.as_tensor((tx - self.t_mean_) / self.t_std_, dtype=_DT)])
            model.set_data(X, y)
            model.set_mode("guide")
        new.gp_ = model
        return new
