"""The contracts criticism types against: ``EffectObjective`` (physics.effect_objective) and the
abstract ``Effect`` (physics.effects.base)."""
from __future__ import annotations

import subprocess
import sys

import pytest

from physics import FlopController, TrajectoryObjective, simulate
from physics.effect_objective import EffectObjective
from physics.effects import EFFECT_TYPES, Effect, effect_from_config
from physics.objective import Objective
from physics.push import PushObjective, generate_push_data, push_space


def test_the_trajectory_error_is_an_effect_objective_and_the_push_toy_is_not() -> None:
    data = simulate(controller=FlopController(heading=0.0), duration=0.3)
    with TrajectoryObjective(data, loss="squared", n_workers=0) as objective:
        assert isinstance(objective, EffectObjective) and isinstance(objective, Objective)
        extended = objective.with_effects([EFFECT_TYPES["sensor_bias"]()])
        assert isinstance(extended, EffectObjective) and isinstance(objective.select([0]), EffectObjective)
    J, S = generate_push_data([1.0, 0.4], n=4, noise_std=0.0, seed=0)
    toy = PushObjective(J, S, space=push_space())
    assert isinstance(toy, Objective) and not isinstance(toy, EffectObjective)


def test_the_contract_module_loads_neither_the_simulator_nor_the_effects() -> None:
    code = ("import sys, physics.effect_objective; "
            "print([m for m in ('dartpy', 'physics.trajectory_objective', 'physics.effects') if m in sys.modules])")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_an_effect_must_declare_parameters_and_apply() -> None:
    class ParametersOnly(Effect):
        name = "parameters_only"

        def parameters(self) -> tuple:
            return ()

    with pytest.raises(TypeError, match="abstract"):
        Effect()
    with pytest.raises(TypeError, match="apply"):
        ParametersOnly()


@pytest.mark.parametrize("name", sorted(EFFECT_TYPES))
def test_every_effect_fulfils_the_contract(name: str) -> None:
    effect = EFFECT_TYPES[name]()
    assert isinstance(effect, Effect) and effect.name == name
    assert effect_from_config(effect.config()) == effect
    assert all(p.lower <= p.nominal <= p.upper for p in effect.parameters())
