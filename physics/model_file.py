"""The model file: which effects a model of the T6 carries, so that another command can use it.

``tensegrid diagnose`` writes ``DIR/model.json`` with the model it ends with (the components of
the mismatch stage, then the effects it found, in the order their parameters extend θ) and that
model's θ̂; ``tensegrid identify --model DIR/model.json`` identifies with those effects, their
parameters inside their own boxes (:class:`~physics.effects.Effect.parameters`)::

    {"effects": [{"effect": "tension_limited_actuator"}, {"effect": "cable_anchors"}],
     "theta": {"rod_length": 1.7, ..., "anchor_offset": 0.061}}

``theta`` is a record of where the writer ended (identify does not read it; ``tensegrid simulate
--model`` starts from it, :func:`read_model_theta`). ``effects_by_name``
turns ``--effects a b`` into the same list.
"""
from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence

from physics.effects import EFFECT_TYPES, Effect, effect_from_config, model_space
from physics.errors import ParameterError

__all__ = ["write_model_file", "read_model_file", "read_model_theta", "effects_by_name"]


def write_model_file(path: str | os.PathLike[str], effects: Sequence[Effect],
                     theta: Mapping[str, float] | None = None) -> None:
    """Write ``effects`` (and θ by name, SI) as the model file of the module docstring."""
    record = {"effects": [e.config() for e in effects], "theta": None if theta is None else dict(theta)}
    with open(path, "w") as fh:
        json.dump(record, fh, indent=1)


def _read_record(path: str | os.PathLike[str]) -> object:
    """The JSON of a model file; ParameterError when it cannot be read or is no JSON."""
    try:
        with open(path) as fh:
            return json.load(fh)
    except OSError as exc:
        raise ParameterError(f"cannot read the model file {os.fspath(path)!r}: {exc.strerror}; pass the "
                             "model.json that tensegrid diagnose wrote.") from None
    except json.JSONDecodeError as exc:
        raise ParameterError(f"the model file {os.fspath(path)!r} is not JSON ({exc.msg}, line {exc.lineno}); pass "
                             "the model.json that tensegrid diagnose wrote.") from None


def read_model_file(path: str | os.PathLike[str]) -> tuple[Effect, ...]:
    """The effects of a model file; ParameterError names the file and what is wrong with it."""
    record = _read_record(path)
    configs = record.get("effects") if isinstance(record, dict) else None
    if not isinstance(configs, list) or not all(isinstance(c, dict) for c in configs):
        raise ParameterError(f"the model file {os.fspath(path)!r} needs a list 'effects' of effect configurations "
                             '(e.g. {"effects": [{"effect": "cable_anchors"}]}).')
    effects = tuple(effect_from_config(c) for c in configs)
    model_space(effects)        # an effect listed twice, or parameters that collide, are refused here
    return effects


def read_model_theta(path: str | os.PathLike[str]) -> dict[str, float]:
    """The θ a model file records by name [SI] (where its writer ended), {} when it records none;
    ParameterError for a ``theta`` that is not a mapping of names to finite numbers."""
    record = _read_record(path)
    theta = record.get("theta") if isinstance(record, dict) else None
    if theta is None:
        return {}
    if not isinstance(theta, dict) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                              and math.isfinite(v) for v in theta.values()):
        raise ParameterError(f"the model file {os.fspath(path)!r} needs 'theta' to map parameter names to finite "
                             'numbers (e.g. {"theta": {"rod_length": 1.7}}), or null.')
    return {str(name): float(value) for name, value in theta.items()}


def effects_by_name(names: Sequence[str]) -> tuple[Effect, ...]:
    """Effects with default options from their names (physics.effects.EFFECT_TYPES), in that order."""
    unknown = [n for n in names if n not in EFFECT_TYPES]
    if unknown or not names:
        what = f"unknown effect(s) {unknown}" if unknown else "no effect named"
        raise ParameterError(f"{what}; known effects are {', '.join(sorted(EFFECT_TYPES))}.")
    effects = tuple(EFFECT_TYPES[n]() for n in names)
    model_space(effects)
    return effects
