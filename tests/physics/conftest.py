"""Shared fixtures of the physics tests: simulated data are made once per session."""
from __future__ import annotations

import pytest

from physics import FlopController, ParameterSpace, simulate


@pytest.fixture(scope="session")
def space() -> ParameterSpace:
    return ParameterSpace.t6()


@pytest.fixture(scope="session")
def flop_data():
    """3 s of the nominal robot flopping toward +x (noise-free, with exact velocities)."""
    return simulate(controller=FlopController(heading=0.0), duration=3.0)
