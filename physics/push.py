"""The 1-D point-pushing toy of Zhu et al. 2018 (Sec. IV-C, eq. "push_eq"): a cheap simulator.

A point of mass ``m`` [kg] at rest receives an impulse ``J = F t`` [N*s] and slides against
kinetic friction ``mu`` until it stops. With the paper's equations ``F t = mu m t_1 = m v_0`` and
``S = v_0 t_1 / 2`` (gravity folded into ``mu``, as in the paper) the displacement is::

    S(m, mu; J) = J^2 / (2 m^2 mu)          [m]

Identification is ill-posed: every (m, mu) with the same ``m^2 mu`` gives the same S for every
impulse, so data can only pin down the ridge ``m^2 mu = const``. That makes the toy the test bed
of the belief package: a correct posterior must spread along the ridge.

The objective :class:`PushError` follows the protocol of ``belief.identify``: attribute ``space``,
``__call__(theta) -> float`` and ``evaluate_batch(thetas) -> list[tuple[float, str]]``. Its error
is the *sum of squared residuals*::

    E(theta) = sum_k (S(theta; J_k) - S_obs_k)^2          [m^2]

so that with Gaussian observation noise of standard deviation ``noise_std`` the likelihood is
``exp(-E / (2 noise_std^2))`` exactly (``noise_var`` attribute).
"""
from __future__ import annotations

import hashlib
from typing import Sequence

import numpy as np

from physics.errors import ParameterError, PhysicsError
from physics.parameters import Parameter, ParameterSpace

__all__ = ["push_space", "simulate_push", "generate_push_data", "PushError"]


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


def _impulses(impulses: "np.ndarray | Sequence[float]") -> np.ndarray:
    arr = np.asarray(impulses, dtype=float)
    if arr.ndim != 1 or arr.size == 0:
        raise ParameterError(
            f"impulses must be a non-empty 1-D array of impulses F*t in N*s, got shape {arr.shape}."
        )
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ParameterError("impulses must be finite and non-negative (N*s); got a NaN, inf or negative value.")
    return arr


def simulate_push(
    theta: "np.ndarray | Sequence[float]",
    impulses: "np.ndarray | Sequence[float]",
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
    theta: "np.ndarray | Sequence[float]",
    *,
    n: int = 8,
    impulses: "np.ndarray | Sequence[float] | None" = None,
    noise_std: float = 0.0,
    seed: "int | np.random.Generator" = 0,
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


class PushError:
    """Objective E(theta) = sum_k (S(theta; J_k) - S_obs_k)^2 [m^2] for the push toy.

    ``impulses`` and ``observed`` have shape ``K``. ``noise_std`` (m), when known, sets
    ``noise_var = noise_std^2`` so that exp(-E / (2 noise_var)) is the exact Gaussian likelihood.
    ``fail_above``: a mass above this value raises :class:`PhysicsError` (a stand-in for a diverging
    simulation, used to test failure handling); ``None`` disables it.
    """

    def __init__(
        self,
        impulses: "np.ndarray | Sequence[float]",
        observed: "np.ndarray | Sequence[float]",
        *,
        space: ParameterSpace | None = None,
        noise_std: float | None = None,
        fail_above: float | None = None,
    ) -> None:
        self.space = space or push_space()
        if self.space.names != ("m", "mu"):
            raise ParameterError(
                f"PushError needs a space with parameters ('m', 'mu'), got {self.space.names}; use push_space()."
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

    @property
    def n_observations(self) -> int:
        """Number of scalar residuals K in E."""
        return int(self.impulses.size)

    @property
    def noise_var(self) -> float | None:
        """Observation noise variance [m^2], or None when unknown."""
        return None if self.noise_std is None else float(self.noise_std) ** 2

    def fingerprint(self) -> dict[str, object]:
        """JSON-able identity of the data and options (a journal refuses another data set)."""
        h = hashlib.sha256(np.ascontiguousarray(self.impulses).tobytes() + np.ascontiguousarray(self.observed).tobytes())
        return {"kind": "push", "data_sha256": h.hexdigest(), "noise_std": self.noise_std, "fail_above": self.fail_above}

    def __call__(self, theta: "np.ndarray | Sequence[float]") -> float:
        th = self.space.as_array(theta)
        if th.ndim != 1:
            raise ParameterError(f"PushError takes one theta of shape (2,), got {th.shape}; use evaluate_batch.")
        if self.fail_above is not None and th[0] > self.fail_above:
            raise PhysicsError(f"push toy: mass {th[0]!r} kg above fail_above={self.fail_above!r} (simulated divergence).")
        S = simulate_push(th, self.impulses, space=self.space)
        return float(np.sum((S - self.observed) ** 2))

    def evaluate_batch(self, thetas: np.ndarray) -> list[tuple[float, str]]:
        """E for each row of ``thetas`` (``n x 2``): a list of ``(error, status)``, status "ok" or "failed"."""
        out: list[tuple[float, str]] = []
        for th in np.atleast_2d(np.asarray(thetas, dtype=float)):
            try:
                out.append((self(th), "ok"))
            except PhysicsError:
                out.append((float("nan"), "failed"))
        return out
