"""The 1-D point-pushing toy of Zhu et al. 2018 (Sec. IV-C, eq. "push_eq"): a cheap simulator.

A point of mass ``m`` [kg] at rest receives an impulse ``J = F t`` [N*s] and slides against
kinetic friction ``mu`` until it stops. With the paper's equations ``F t = mu m t_1 = m v_0`` and
``S = v_0 t_1 / 2`` (gravity folded into ``mu``, as in the paper) the displacement is::

    S(m, mu; J) = J^2 / (2 m^2 mu)          [m]

Identification is ill-posed: every (m, mu) with the same ``m^2 mu`` gives the same S for every
impulse, so data can only pin down the ridge ``m^2 mu = const``. That makes the toy the test bed
of the belief package: a correct posterior must spread along the ridge.

The objective :class:`PushObjective` implements the contract of :mod:`physics.objective`. Its error
is the *sum of squared residuals*::

    E(theta) = sum_k (S_obs_k - S(theta; J_k))^2          [m^2]

so that with Gaussian observation noise of standard deviation ``noise_std`` the likelihood is
``exp(-E / (2 noise_std^2))`` exactly (``noise_var`` attribute). Its segments ``w0 .. w{W-1}``
are the pushes, in the given order, split into ``windows`` contiguous groups whose sizes differ
by at most one (fewer groups when there are fewer pushes than ``windows``); part j is the sum
above over group j, and the residuals of group j are the column ``S_obs_k - S(theta; J_k)`` (K_j, 1).
"""
from __future__ import annotations

import hashlib
from collections.abc import Sequence

import numpy as np

from physics.errors import ParameterError, PhysicsError
from physics.objective import BatchResult, OnResult, check_windows, evaluate_row, residual_row
from physics.parameters import Parameter, ParameterSpace
from physics.pool import map_serial

__all__ = ["push_space", "simulate_push", "generate_push_data", "PushObjective"]


def push_space(
    *, mass: tuple[float, float] = (0.5, 1.5), friction: tuple[float, float] = (0.1, 1.0)
) -> ParameterSpace:
    """The parameter space of the push toy: ``m`` [kg] and ``mu`` [-] (gravity folded in).

    Default box: m in [0.5, 1.5] kg, mu in [0.1, 1.0]; nominal values are the box centres.
    """
    (m_lo, m_hi), (mu_lo, mu_hi) = mass, friction
    return ParameterSpace((
        Parameter("m", "kg", 0.5 * (m_lo + m_hi), float(m_lo), float(m_hi), "mass of the pushed point"),
        Parameter("mu", "1", 0.5 * (mu_lo + mu_hi), float(mu_lo), float(mu_hi),
                  "kinetic friction coefficient (gravity folded in, as in the paper)"),
    ))


def _impulses(impulses: np.ndarray | Sequence[float]) -> np.ndarray:
    arr = np.asarray(impulses, dtype=float)
    if arr.ndim != 1 or arr.size == 0:
        raise ParameterError(
            f"impulses must be a non-empty 1-D array of impulses F*t in N*s, got shape {arr.shape}."
        )
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ParameterError("impulses must be finite and non-negative (N*s); got a NaN, inf or negative value.")
    return arr


def simulate_push(
    theta: np.ndarray | Sequence[float],
    impulses: np.ndarray | Sequence[float],
    *,
    space: ParameterSpace | None = None,
) -> np.ndarray:
    """Displacements ``S = J^2 / (2 m^2 mu)`` [m].

    ``theta``: shape ``2`` or ``n x 2`` in the order (m, mu); ``impulses``: shape ``K`` [N*s].
    Returns shape ``K`` or ``n x K``. Bounds are not enforced (only physical validity: m, mu > 0).
    """
    space = space or push_space()
    th = space.as_array(theta, check_bounds=False)
    J = _impulses(impulses)
    m, mu = th[..., 0, None], th[..., 1, None]
    return J**2 / (2.0 * m**2 * mu)


def generate_push_data(
    theta: np.ndarray | Sequence[float],
    *,
    n: int = 8,
    impulses: np.ndarray | Sequence[float] | None = None,
    noise_std: float = 0.0,
    seed: int | np.random.Generator = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Synthetic observations ``(impulses K, displacements K)`` for the true ``theta`` (shape 2).

    Impulses default to ``n`` values evenly spaced in [0.5, 1.5] N*s; Gaussian noise of standard
    deviation ``noise_std`` [m] is added with ``numpy.random.default_rng(seed)``.
    """
    if impulses is None:
        if int(n) < 1:
            raise ParameterError(f"n must be a positive number of pushes, got {n!r}.")
        impulses = np.linspace(0.5, 1.5, int(n))
    J = _impulses(impulses)
    if not (np.isfinite(noise_std) and noise_std >= 0):
        raise ParameterError(f"noise_std must be a finite non-negative length in m, got {noise_std!r}.")
    S = simulate_push(theta, J)
    if np.ndim(S) != 1:
        raise ParameterError(f"theta must be a single parameter vector of shape (2,), got {np.shape(theta)}.")
    rng = np.random.default_rng(seed)
    return J, S + noise_std * rng.standard_normal(S.shape)


class PushObjective:
    """Objective E(theta) = sum_k (S_obs_k - S(theta; J_k))^2 [m^2] for the push toy.

    ``impulses`` and ``observed`` have shape ``K``. ``noise_std`` (m), when known, sets
    ``noise_var = noise_std^2`` so that exp(-E / (2 noise_var)) is the exact Gaussian likelihood.
    ``fail_above``: a mass above this value raises :class:`PhysicsError` (a stand-in for a diverging
    simulation, used to test failure handling); ``None`` disables it. ``windows``: the number of
    contiguous groups of pushes that make the segments (module docstring).
    """

    def __init__(
        self,
        impulses: np.ndarray | Sequence[float],
        observed: np.ndarray | Sequence[float],
        *,
        space: ParameterSpace | None = None,
        noise_std: float | None = None,
        fail_above: float | None = None,
        windows: int = 2,
    ) -> None:
        self.space = space or push_space()
        if self.space.names != ("m", "mu"):
            raise ParameterError(
                f"PushObjective needs a space with parameters ('m', 'mu'), got {self.space.names}; use push_space()."
            )
        self.impulses = _impulses(impulses)
        obs = np.asarray(observed, dtype=float)
        if obs.shape != self.impulses.shape:
            raise ParameterError(
                f"observed must have the shape of impulses {self.impulses.shape}, got {obs.shape}."
            )
        if not np.all(np.isfinite(obs)):
            raise ParameterError("observed displacements contain NaN or inf; drop those pushes.")
        self.observed = obs
        if noise_std is not None and not (np.isfinite(noise_std) and noise_std > 0):
            raise ParameterError(f"noise_std must be a positive length in m or None, got {noise_std!r}.")
        self.noise_std = noise_std
        self.fail_above = fail_above
        n_windows = check_windows(windows, "groups of pushes")
        self.windows = n_windows
        self._groups = np.array_split(np.arange(self.impulses.size), min(n_windows, self.impulses.size))

    @property
    def segments(self) -> tuple[str, ...]:
        """Names ``w0 .. w{W-1}`` of the contiguous groups of pushes, W = min(windows, K)."""
        return tuple(f"w{j}" for j in range(len(self._groups)))

    @property
    def n_observations(self) -> int:
        """Number of scalar residuals K in E."""
        return int(self.impulses.size)

    @property
    def noise_var(self) -> float | None:
        """Observation noise variance [m^2], or None when unknown."""
        return None if self.noise_std is None else float(self.noise_std) ** 2

    @property
    def noise_floor(self) -> float | None:
        """What the noise alone leaves per residual: its declared variance (the impulses are exact)."""
        return self.noise_var

    def fingerprint(self) -> dict[str, object]:
        """JSON-able identity of the data and options (a journal refuses another data set)."""
        h = hashlib.sha256(np.ascontiguousarray(self.impulses).tobytes())
        h.update(np.ascontiguousarray(self.observed).tobytes())
        return {"kind": "push", "data_sha256": h.hexdigest(), "noise_std": self.noise_std,
                "fail_above": self.fail_above, "windows": self.windows, "segments": list(self.segments)}

    def _residual(self, theta: np.ndarray | Sequence[float]) -> np.ndarray:
        """S_obs - S(theta) (K,) [m]; raises PhysicsError above ``fail_above``."""
        th = self.space.as_array(theta)
        if th.ndim != 1:
            raise ParameterError(f"PushObjective takes one theta of shape (2,), got {th.shape}; use evaluate_batch.")
        if self.fail_above is not None and th[0] > self.fail_above:
            raise PhysicsError(f"push toy: mass {th[0]!r} kg above fail_above={self.fail_above!r} "
                               "(simulated divergence).")
        return self.observed - simulate_push(th, self.impulses, space=self.space)

    def evaluate_parts(self, theta: np.ndarray | Sequence[float]) -> np.ndarray:
        """Per-segment errors (S,) [m^2]: sum of squared residuals over each group of pushes."""
        r = self._residual(theta)
        return np.array([np.sum(r[group] ** 2) for group in self._groups])

    def residuals(self, theta: np.ndarray | Sequence[float]) -> list[np.ndarray]:
        """Residuals S_obs - S(theta) per segment: S arrays (K_j, 1) [m] in push order."""
        r = self._residual(theta)
        return [r[group, None] for group in self._groups]

    def __call__(self, theta: np.ndarray | Sequence[float]) -> float:
        """E(theta) [m^2] for theta of shape (2,), the sum of the parts."""
        return float(self.evaluate_parts(theta).sum())

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: OnResult | None = None) -> BatchResult:
        """E and parts at each row of ``thetas`` (``n x 2``), in this process; failures are recorded
        ("diverged" for :class:`PhysicsError`, "failed" for another tensegrid error), not raised.
        on_result(k, error, status, seconds, message, parts (S,)) is called after each row."""
        arr = np.atleast_2d(np.asarray(thetas, dtype=float))
        if arr.ndim != 2 or arr.shape[1] != self.space.dim:
            raise ParameterError(f"thetas must have shape (n, {self.space.dim}) in the order (m, mu), got {arr.shape}.")
        relay = None if on_result is None else (lambda k, row: on_result(k, *row))
        return BatchResult.from_rows(map_serial(evaluate_row, self, list(arr), relay), len(self.segments))

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        """:meth:`residuals` at each row of ``thetas`` (``n x 2``), None where the evaluation failed."""
        arr = np.atleast_2d(np.asarray(thetas, dtype=float))
        if arr.ndim != 2 or arr.shape[1] != self.space.dim:
            raise ParameterError(f"thetas must have shape (n, {self.space.dim}) in the order (m, mu), got {arr.shape}.")
        return map_serial(residual_row, self, list(arr))
