"""Rule 5 of the verdicts end to end: a decoder that holds fixed what trades off with a parameter."""
from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from belief import identify
from belief.grid import Grid
from belief.verdicts import VerdictConfig
from embeddings.base import Decoder
from physics.push import PushObjective, generate_push_data


class MassLine(Decoder):
    """z in [0, 1] -> (m over its box, μ held at ``mu_unit`` of its box): a 1-D image without the truth."""

    def __init__(self, space: Any, mu_unit: float) -> None:
        self.space, self.mu_unit = space, mu_unit

    @property
    def dim(self) -> int:
        return 1

    @property
    def bounds(self) -> np.ndarray:
        return np.array([[0.0, 1.0]])

    def _decode_unit(self, z: np.ndarray) -> np.ndarray:
        return np.column_stack([z[:, 0], np.full(len(z), self.mu_unit)])

    def config(self) -> dict[str, Any]:
        return {"kind": "mass-line", "mu_unit": self.mu_unit}

    @classmethod
    def from_config(cls, config: dict[str, Any], space: Any) -> "MassLine":
        return cls(space, config["mu_unit"])


@pytest.fixture(scope="module")
def line_runs():
    """The push toy (S = J²/(2 m² μ), truth m = 1, μ = 0.4) searched along m with μ held at 0.82."""
    truth = np.array([1.0, 0.4])
    J, S = generate_push_data(truth, n=8, noise_std=0.05, seed=0)
    obj = PushObjective(J, S, noise_std=0.05)
    dec = MassLine(obj.space, mu_unit=0.8)
    grid = Grid.for_decoder(dec, points_per_dim=81)
    runs = {flag: identify(obj, dec, grid, budget=12, seed=0, progress=False, verdict_config=VerdictConfig(refit=flag))
            for flag in (False, True)}
    return runs, truth


def test_without_the_local_fit_the_held_direction_makes_a_sharp_wrong_interval(line_runs) -> None:
    runs, truth = line_runs
    m = runs[False].belief.marginals().sel(parameter="m")
    assert str(m["verdict"].values) == "identified"
    assert not (float(m["lower"]) <= truth[0] <= float(m["upper"]))        # m²μ fits, m does not
    assert runs[False].belief.attrs["local_fit"] == {"skipped": "VerdictConfig.refit is off"}


def test_the_local_fit_over_all_parameters_withdraws_the_verdict(line_runs) -> None:
    runs, _ = line_runs
    belief = runs[True].belief
    m = belief.marginals().sel(parameter="m")
    reason = str(m["reason"].values)
    assert str(m["verdict"].values) == "not identified" and "a local fit over all parameters" in reason
    assert "decoder held those fixed" in reason          # a 1-D decoder over 2 parameters made P
    local = belief.attrs["local_fit"]
    assert local["evaluations"] == 2 + 1 + 3 and local["error"] <= local["start_error"]
    assert local["std"][0] > (1.5 - 0.5) / np.sqrt(12)            # m's local std: beyond the prior's
    assert "local fit over all parameters" in runs[True].summary()
    assert "local fit" not in runs[False].summary()
