"""The model's actuator on data with encoder readings: the motor model, or the law read from the readings.

The actuator stage (physics.actuator_readings) fits laws from commands to readings. The model's
own motor (physics.actuators.MotorActuator) predicts the same readings with nothing fitted: driven
along the observed cable motion at the prior box's nominal θ (physics.predictor.reconstruct_actuators),
its rest lengths less the encoders' zero are what the encoders would read. Over the cables and
samples the stage fitted, each has an RMS residual r [m] (the motor's with each cable's mean
residual taken out, the offset per cable the laws fit too); the law replaces the motor when

    r_law < ratio · r_motor          (ratio 0.1 by default)

and the motor stays otherwise: readings the motor already explains (the library's own robot) need
no law. The law's parts are fitted and the motor runs at a θ nobody has identified yet (on the
library's own robot, θ off nominal by up to 10 % leaves the motor 6-8 mm, the best law 10 mm), so
only a law of another class, ten times closer, replaces it and the motor parameters it makes inert
(:data:`physics.effects.MOTOR_PARAMETERS`, which a measured actuator's model holds fixed).
"""
from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import xarray as xr

from physics.actuator_readings import ActuatorConfig, identify_actuator
from physics.actuator_summary import ActuatorFit
from physics.effects.actuation import MeasuredActuator
from physics.errors import ParameterError
from physics.model_options import ModelOptions
from physics.parameters import ParameterSpace
from physics.trajectory import regular_clock

__all__ = ["ActuatorChoice", "ActuatorMode", "choose_actuator", "has_readings", "motor_readings_rms",
           "add_actuator_option"]

#: "auto": the law when it beats the motor (module docstring); "measured": the law whenever one fits;
#: "model": always the motor model (the stage is not run)
ActuatorMode = Literal["auto", "measured", "model"]


@dataclass(frozen=True, eq=False, kw_only=True)
class ActuatorChoice:
    """What the model's actuator is and why: the stage's ``fit``, the RMS residuals [m] of the law
    (``law_rms``) and of the motor model at nominal θ (``motor_rms``) on the same readings, the
    ``effect`` that puts the law in the model (None: the motor stays) and the parameters it makes
    ``inert``."""

    fit: ActuatorFit
    law_rms: float
    motor_rms: float
    effect: MeasuredActuator | None
    inert: tuple[str, ...]
    reason: str

    @property
    def measured(self) -> bool:
        """Whether the law read from the encoders is the model's actuator."""
        return self.effect is not None

    def lines(self) -> list[str]:
        """Plain-text lines for a summary: what was read, which actuator the model uses, why (the
        inert parameters are the caller's to report: identify holds them, diagnose keeps them)."""
        head = "actuator read from the encoders: " + (self.fit.describe() if self.fit.identified else
                                                       "no law fits the readings")
        return [head, self.reason]

    def as_dict(self) -> dict[str, object]:
        """A JSON-able record (result.config["actuator"])."""
        return {"measured": self.measured, "law_rms": self.law_rms, "motor_rms": self.motor_rms, "lines": self.lines(),
                "effect": None if self.effect is None else self.effect.config(), "inert": list(self.inert),
                "reason": self.reason, "describe": self.fit.describe() if self.fit.identified else None}


def motor_readings_rms(trajectories: Sequence[xr.Dataset], fit: ActuatorFit, space: ParameterSpace,
                       options: ModelOptions | None = None) -> float:
    """RMS [m] of the motor model's predicted readings (module docstring) against the readings, over
    the cables the stage fitted (``fit.actuated``) and the samples with a reading, each cable's mean
    residual taken out (the laws fit an offset per cable too); NaN when the model
    diverges along the observed motion. ``space``: a prior box holding the T6's parameters (an
    effect's are left out: the motor runs in the bare T6)."""
    from physics.errors import PhysicsError
    from physics.predictor import ObservedStates, reconstruct_actuators
    from physics.tensegrity import T6Model

    cables = list(fit.actuated)
    if not cables:
        return math.nan
    t6 = set(ParameterSpace.t6().names)
    bare = ParameterSpace.from_parameters(p for p in space if p.name in t6)   # the motor, without effects
    model = T6Model(bare.nominal, space=bare, options=options)
    diffs: list[np.ndarray] = []
    for ds in trajectories:
        obs = ObservedStates(regular_clock(ds), ahead=None)
        if obs.readings is None:
            raise ParameterError("every trajectory needs rest_length readings to compare the motor model with them.")
        try:
            rest, _ = reconstruct_actuators(obs, model)
        except PhysicsError:
            return math.nan
        offset = model.encoder_offset if obs.reference == "encoder" else np.zeros(24)
        diffs.append((rest - offset - obs.readings)[:, cables])
    residual = np.concatenate(diffs)
    residual = residual - np.nanmean(residual, axis=0)          # each cable's offset, as the laws fit one
    ok = np.isfinite(residual)
    total, count = float((residual[ok] ** 2).sum()), int(ok.sum())
    return math.sqrt(total / count) if count else math.nan


def has_readings(trajectories: Sequence[xr.Dataset]) -> bool:
    """Whether every trajectory carries encoder readings (``rest_length``), so the actuator can be read."""
    return bool(trajectories) and all("rest_length" in ds.data_vars for ds in trajectories)


def choose_actuator(trajectories: Sequence[xr.Dataset], space: ParameterSpace, *, mode: ActuatorMode = "auto",
                    config: ActuatorConfig | None = None, options: ModelOptions | None = None,
                    ratio: float = 0.1) -> ActuatorChoice | None:
    """The model's actuator for ``trajectories`` (module docstring); None when ``mode`` is "model" or
    a trajectory has no ``rest_length`` (then nothing changes). ``space``: the T6's prior box, whose
    nominal θ the motor model runs at; ``ratio``: how much better the law must fit."""
    if mode not in ("auto", "measured", "model"):
        raise ParameterError(f"actuator mode must be 'auto', 'measured' or 'model', got {mode!r}.")
    if not 0 < ratio <= 1:
        raise ParameterError(f"the actuator choice's ratio must lie in (0, 1], got {ratio!r}.")
    if mode == "model" or not has_readings(trajectories):
        if mode == "measured":
            raise ParameterError("--actuator measured needs encoder readings (rest_length) in every data file; "
                                 "record them, or use --actuator auto.")
        return None
    k = float(space.nominal[space.index("stiffnessActive")])
    fit = identify_actuator(list(trajectories), config or ActuatorConfig(stiffness=k))
    if not fit.identified:
        if mode == "measured":
            raise ParameterError("--actuator measured: no actuator law fits the encoder readings "
                                 f"({'; '.join(f.message for f in fit.findings)}); use --actuator auto.")
        return ActuatorChoice(fit=fit, law_rms=math.nan, motor_rms=math.nan, effect=None, inert=(),
                              reason="the model keeps its motor: no actuator law fits the readings")
    motor = motor_readings_rms(trajectories, fit, space, options)
    better = not math.isfinite(motor) or fit.rms < ratio * motor
    figures = f"the law fits the readings to {1e3 * fit.rms:.2g} mm RMS, the motor model at nominal θ to " \
              f"{1e3 * motor:.2g} mm"
    if mode == "auto" and not better:
        return ActuatorChoice(fit=fit, law_rms=fit.rms, motor_rms=motor, effect=None, inert=(),
                              reason=f"the model keeps its motor: {figures}")
    effect = MeasuredActuator.from_fit(fit)
    return ActuatorChoice(fit=fit, law_rms=fit.rms, motor_rms=motor, effect=effect,
                          inert=tuple(n for n in effect.inert if n in space.names),
                          reason=f"the measured law is the model's actuator: {figures}")


def add_actuator_option(group: argparse._ArgumentGroup) -> None:
    """``--actuator auto|measured|model`` (:data:`ActuatorMode`), for the commands that build a model from data."""
    group.add_argument("--actuator", choices=["auto", "measured", "model"], default="auto",
                       help="with encoder readings (rest_length) in the data: 'auto' puts the actuator law read from "
                            "them in the model when it fits the readings better than the motor model (default), "
                            "'measured' always, 'model' keeps the motor model (physics.actuator_choice)")
