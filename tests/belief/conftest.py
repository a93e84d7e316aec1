"""Shared fixtures of the belief tests: cheap objectives with known answers."""
from __future__ import annotations

import numpy as np
import pytest

from physics.parameters import Parameter, ParameterSpace
from physics.push import PushObjective, generate_push_data, push_space


def _unit_space(D: int) -> ParameterSpace:
    return ParameterSpace(tuple(Parameter(f"x{i}", "1", 0.5, 0.0, 1.0, minimum=-1.0) for i in range(D)))


class Branin15:
    """Branin on two active coordinates (3 and 11) of a 15-D unit box; min 0.397887 (Wang et al. 2016)."""

    minimum = 0.397887

    def __init__(self) -> None:
        self.space = _unit_space(15)

    def __call__(self, th: np.ndarray) -> float:
        x1, x2 = -5 + 15 * th[3], 15 * th[11]
        return float((x2 - 5.1 / (4 * np.pi**2) * x1**2 + 5 / np.pi * x1 - 6) ** 2
                     + 10 * (1 - 1 / (8 * np.pi)) * np.cos(x1) + 10)


class Hartmann6:
    """Hartmann-6 on [0, 1]^6; min -3.32237."""

    minimum = -3.32237
    _A = np.array([[10, 3, 17, 3.5, 1.7, 8], [0.05, 10, 17, 0.1, 8, 14], [3, 3.5, 1.7, 10, 17, 8],
                   [17, 8, 0.05, 10, 0.1, 14]])
    _P = 1e-4 * np.array([[1312, 1696, 5569, 124, 8283, 5886], [2329, 4135, 8307, 3736, 1004, 9991],
                          [2348, 1451, 3522, 2883, 3047, 6650], [4047, 8828, 8732, 5743, 1091, 381]])
    _alpha = np.array([1.0, 1.2, 3.0, 3.2])

    def __init__(self) -> None:
        self.space = _unit_space(6)

    def __call__(self, th: np.ndarray) -> float:
        return float(-np.sum(self._alpha * np.exp(-np.sum(self._A * (th - self._P) ** 2, axis=1))))


@pytest.fixture
def unit_space():
    return _unit_space


@pytest.fixture
def branin15() -> Branin15:
    return Branin15()


@pytest.fixture
def hartmann6() -> Hartmann6:
    return Hartmann6()


@pytest.fixture
def push_problem():
    """Factory: (objective, truth) for the push toy with 8 pushes and Gaussian noise."""

    def make(truth=(1.0, 0.4), *, noise_std: float = 0.05, seed: int = 0, **kw):
        truth = np.asarray(truth, dtype=float)
        J, S = generate_push_data(truth, n=8, noise_std=noise_std, seed=seed)
        return PushObjective(J, S, space=push_space(), noise_std=noise_std, **kw), truth

    return make
