"""What the user knows goes in: measurements ``NAME=VALUE±SD`` and fixed values ``NAME=VALUE``.

A researcher who weighed a rod or measured a length states it as a :class:`Measurement` of a
quantity g (physics.quantities: ``rod_mass``, ``total_mass``, ``rod_inertia`` or any parameter)
with a standard deviation; the measurement is a Gaussian prior on g(θ)::

    r_i(θ) = (g_i(θ) − value_i) / sd_i          (standardized residual, no unit)
    log p(θ) = −½ Σ_i r_i(θ)²                    (up to a constant)

:class:`MeasurementPrior` evaluates it on rows θ of the free parameters (the fixed ones are
inserted first, physics.fixed) and gives its Jacobian in the unit box, so that a Gauss-Newton or
Laplace step adds GᵀG to JᵀJ/σ². Measuring a quantity that trajectories cannot pin (the mass scale,
physics.scaling) is how an identification gets it.

Text forms (the command line's ``--measured`` and ``--fix``; spaces allowed, SI units)::

    rod_mass=3.02+-0.05    rod_length=1.65±0.002    motor_friction=8.5e-5

:func:`check_measurements` refuses, each with one line that names the problem and the fix: an
unknown name, a unit slip, a value outside what the prior box allows, a physically impossible
value, a name both fixed and measured, a name given twice.
"""
from __future__ import annotations

import argparse
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from physics.errors import MeasurementError
from physics.fixed import FixedParameters, check_fixed, free_values, insert_fixed
from physics.fixed import free_space as _free_space
from physics.objective import Objective
from physics.parameters import ParameterSpace
from physics.quantities import (
    QUANTITIES,
    check_value,
    depends_on,
    known_quantities,
    measured_values,
    quantity_unit,
    rod_inertia,
    rod_mass,
    total_mass,
    unit_text,
)

__all__ = ["Measurement", "MeasurementPrior", "QUANTITIES", "rod_mass", "total_mass", "rod_inertia",
           "measured_values", "parse_measurement", "parse_fixed", "check_measurements", "add_measurement_options",
           "measurement_prior_from_args"]

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_MEASURED = re.compile(rf"^\s*(\w+)\s*=\s*({_NUMBER})\s*(?:\+-|\+/-|±)\s*({_NUMBER})\s*$")
_FIXED = re.compile(rf"^\s*(\w+)\s*=\s*({_NUMBER})\s*$")
_MEASURED_FORM = "NAME=VALUE+-SD or NAME=VALUE±SD in SI units, e.g. rod_mass=3.02+-0.05"
_FIXED_FORM = "NAME=VALUE in SI units, e.g. rod_length=1.74"

#: Step in unit-box coordinates of the central differences of :meth:`MeasurementPrior.jacobian`.
_STEP = 1e-5


@dataclass(frozen=True)
class Measurement:
    """A measured ``value`` of quantity ``name`` with standard deviation ``sd`` (both in its SI unit)."""

    name: str
    value: float
    sd: float

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise MeasurementError(f"a measurement names a quantity (letters, digits, _), got {self.name!r}; "
                                   "e.g. Measurement('rod_mass', 3.02, 0.05).")
        for attr in ("value", "sd"):
            raw = getattr(self, attr)
            if isinstance(raw, bool) or not isinstance(raw, (int, float, np.floating, np.integer)):
                raise MeasurementError(f"measurement {self.name}: {attr} must be a number, got {raw!r}.")
            object.__setattr__(self, attr, float(raw))
        if not math.isfinite(self.value):
            raise MeasurementError(f"measurement {self.name}: the value must be finite, got {self.value!r}.")
        if not (math.isfinite(self.sd) and self.sd > 0):
            raise MeasurementError(f"measurement {self.name}: the standard deviation must be a finite number > 0, got "
                                   f"{self.sd!r}; give the measurement's uncertainty, e.g. {self.name}="
                                   f"{self.value:g}+-{0.01 * abs(self.value) or 1:g}.")


def parse_measurement(text: str) -> Measurement:
    """``"NAME=VALUE+-SD"`` (or ``±``, ``+/-``; spaces allowed) as a :class:`Measurement`."""
    match = _MEASURED.match(text)
    if match is None:
        hint = " (a value without an uncertainty is fixed: --fix NAME=VALUE)" if _FIXED.match(text) else ""
        raise MeasurementError(f"measurement {text!r} is not of the form {_MEASURED_FORM}{hint}.")
    return Measurement(match.group(1), float(match.group(2)), float(match.group(3)))


def parse_fixed(text: str) -> tuple[str, float]:
    """``"NAME=VALUE"`` (spaces allowed) as (name, SI value)."""
    match = _FIXED.match(text)
    if match is None:
        hint = " (a value with an uncertainty is measured: --measured NAME=VALUE+-SD)" if _MEASURED.match(text) else ""
        raise MeasurementError(f"fixed value {text!r} is not of the form {_FIXED_FORM}{hint}.")
    return match.group(1), float(match.group(2))


def _given_once(names: Sequence[str], role: str) -> None:
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        how = "combine the measurements into one value+-sd" if role == "measured" else "keep one value"
        raise MeasurementError(f"{role} {twice[0]} is given twice; give each name once ({how}).")


def check_measurements(space: ParameterSpace, measurements: Sequence[Measurement],
                       fixed: Mapping[str, float] | Sequence[tuple[str, float]] = ()) -> None:
    """Raise :class:`MeasurementError` (one line: the problem and the fix) for a name given twice, a
    name both fixed and measured, an unknown name (listing the known ones), an impossible value, a
    unit slip or a value outside the prior box of ``space`` (physics.quantities.check_value), or
    every parameter fixed. ``space`` holds every parameter, the fixed ones too."""
    pairs = list(fixed.items()) if isinstance(fixed, Mapping) else [(str(n), float(v)) for n, v in fixed]
    _given_once([m.name for m in measurements], "measured")
    _given_once([name for name, _ in pairs], "fixed")
    both = sorted({m.name for m in measurements} & {name for name, _ in pairs})
    if both:
        raise MeasurementError(f"{both[0]} is both fixed and measured; fix it (--fix NAME=VALUE) or measure it "
                               "(--measured NAME=VALUE+-SD), not both.")
    for m in measurements:
        if m.name not in known_quantities(space):
            raise MeasurementError(f"measured {m.name}: unknown quantity; the known ones are "
                                   f"{', '.join(known_quantities(space))}.")
        check_value(space, m.name, m.value, role="measured")
    check_fixed(space, dict(pairs))


@dataclass(frozen=True)
class MeasurementPrior:
    """The Gaussian prior of the user's ``measurements`` on the box ``space`` (every parameter), with
    the parameters in ``fixed`` (name -> SI value) held at their values (module docstring); ``inert``:
    those of ``fixed`` held not by the user but because the model no longer reads them (a measured
    actuator makes the motor parameters inert, physics.actuator_choice).

    θ rows are in the order of :attr:`free_space`, the parameters the search sees: (n x D_f) or
    (D_f,). Belief consumes it in two steps: the posterior's log prior over cells (log P of a cell
    gains :meth:`log_density` of its θ) and the local fit's extra rows (the standardized residuals
    and :meth:`jacobian` stacked under the data's, so JᵀJ/σ² gains GᵀG). Validated on construction
    (:func:`check_measurements`).
    """

    space: ParameterSpace
    measurements: tuple[Measurement, ...] = ()
    fixed: Mapping[str, float] = field(default_factory=dict)
    inert: tuple[str, ...] = ()
    free_space: ParameterSpace = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        measurements = tuple(self.measurements)
        if not all(isinstance(m, Measurement) for m in measurements):
            raise MeasurementError("MeasurementPrior.measurements must be Measurement objects; build them with "
                                   "Measurement(name, value, sd) or parse_measurement('NAME=VALUE+-SD').")
        check_measurements(self.space, measurements, self.fixed)
        fixed = {name: float(self.fixed[name]) for name in self.space.names if name in self.fixed}
        object.__setattr__(self, "measurements", measurements)
        object.__setattr__(self, "fixed", MappingProxyType(fixed))
        object.__setattr__(self, "free_space", _free_space(self.space, fixed))
        if not set(self.inert) <= set(fixed):
            raise MeasurementError(f"inert parameters {sorted(set(self.inert) - set(fixed))} must also be fixed.")
        object.__setattr__(self, "inert", tuple(self.inert))

    def with_inert(self, names: Sequence[str]) -> MeasurementPrior:
        """This prior with ``names`` also held at their nominal values as inert, except those the user
        measured or fixed (their values stand)."""
        mine = set(self.fixed) | {m.name for m in self.measurements}
        extra = {n: float(self.space.nominal[self.space.index(n)]) for n in names if n not in mine}
        if not extra:
            return self
        return MeasurementPrior(self.space, self.measurements, {**self.fixed, **extra},
                                inert=tuple(self.inert) + tuple(n for n in self.space.names if n in extra))

    @property
    def units(self) -> tuple[str, ...]:
        """The SI unit of each measurement (M,)."""
        return tuple(quantity_unit(self.space, m.name) for m in self.measurements)

    def full(self, thetas: np.ndarray) -> np.ndarray:
        """Full θ (``D`` or ``n x D``, order of ``space``) from free rows (``D_f`` or ``n x D_f``)."""
        return insert_fixed(self.space, self.fixed, thetas)

    def free(self, thetas: np.ndarray) -> np.ndarray:
        """The free parameters (``D_f`` or ``n x D_f``) of full rows θ (``D`` or ``n x D``, order of ``space``)."""
        return free_values(self.space, self.fixed, thetas)

    def hold(self, objective: Objective) -> Objective:
        """``objective`` (on ``space``) with the fixed parameters held, :class:`~physics.fixed.FixedParameters`;
        ``objective`` itself when nothing is fixed."""
        if not objective.space.same_box(self.space):
            raise MeasurementError(f"the objective's space {list(objective.space.names)} (or its box) is not this "
                                   "prior's; build the MeasurementPrior on objective.space.")
        return FixedParameters(objective, self.fixed) if self.fixed else objective

    def values(self, thetas: np.ndarray) -> np.ndarray:
        """g_i(θ) of each measured quantity at each free row: ``n x D_f`` -> ``n x M`` (units of each)."""
        full = np.atleast_2d(self.full(thetas))
        columns = [measured_values(self.space, full, m.name) for m in self.measurements]
        return np.stack(columns, axis=1) if columns else np.zeros((len(full), 0))

    def residuals(self, thetas: np.ndarray) -> np.ndarray:
        """Standardized residuals r_i = (g_i(θ) − value_i) / sd_i: ``n x D_f`` -> ``n x M`` (no unit)."""
        value = np.array([m.value for m in self.measurements])
        sd = np.array([m.sd for m in self.measurements])
        return (self.values(thetas) - value) / sd

    def log_density(self, thetas: np.ndarray) -> np.ndarray:
        """log p(θ) = −½ Σ_i r_i² at each free row: ``n x D_f`` -> ``(n,)`` (nats, up to a constant)."""
        return -0.5 * np.sum(self.residuals(thetas) ** 2, axis=1)

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """G = ∂r/∂u (``M x D_f``) at one free θ (``D_f``), u = (θ − lower)/(upper − lower) of
        :attr:`free_space`: a measured parameter j gives (upper_j − lower_j)/sd in column j, a derived
        quantity central differences of step 1e-5 in u (one-sided at the box's faces)."""
        space = self.free_space
        point = np.asarray(space.as_array(theta, check_bounds=False), dtype=float)
        if point.ndim != 1:
            raise MeasurementError(f"jacobian takes one θ of shape ({space.dim},), got {point.shape}.")
        width = space.upper - space.lower
        u = (point - space.lower) / width
        G = np.zeros((len(self.measurements), space.dim))
        for i, m in enumerate(self.measurements):
            if m.name in space.names:
                G[i, space.index(m.name)] = width[space.index(m.name)] / m.sd
                continue
            for j in (space.index(n) for n in depends_on(self.space, m.name) if n in space.names):
                up, down = u.copy(), u.copy()
                up[j], down[j] = min(u[j] + _STEP, max(u[j], 1.0)), max(u[j] - _STEP, min(u[j], 0.0))
                pair = self.residuals(space.lower + np.vstack([up, down]) * width)[:, i]
                G[i, j] = (pair[0] - pair[1]) / (up[j] - down[j])
        return G

    def summary(self) -> str:
        """The lines a summary prints: 'Measured by the user' and 'Fixed by the user', "" when both are empty."""
        lines = []
        if self.measurements:
            lines.append("Measured by the user:")
            lines += [f"  {m.name} = {m.value:.6g} ± {m.sd:.3g}{unit_text(unit)}  ({_describe(self.space, m.name)})"
                      for m, unit in zip(self.measurements, self.units, strict=True)]
        user = {n: v for n, v in self.fixed.items() if n not in self.inert}
        if user:
            lines.append("Fixed by the user (not identified):")
            lines += [f"  {name} = {value:.6g}{unit_text(self.space[name].unit)}" for name, value in user.items()]
        if self.inert:
            lines.append("Held at nominal, inert (the measured actuator replaces the motor that read them): "
                         + ", ".join(self.inert))
        return "\n".join(lines)

    def config(self) -> dict[str, Any]:
        """JSON-able record: ``{"kind", "measurements": [{name, value, sd, unit}], "fixed": {name: value}}``."""
        return {"kind": "measurements",
                "measurements": [{"name": m.name, "value": m.value, "sd": m.sd, "unit": unit}
                                 for m, unit in zip(self.measurements, self.units, strict=True)],
                "fixed": dict(self.fixed), **({"inert": list(self.inert)} if self.inert else {})}

    @classmethod
    def from_config(cls, config: Mapping[str, Any], space: ParameterSpace) -> MeasurementPrior:
        """The prior :meth:`config` recorded, on ``space`` (the box with every parameter)."""
        if config.get("kind") != "measurements":
            raise MeasurementError(f"not a MeasurementPrior record (kind {config.get('kind')!r}); pass what "
                                   "MeasurementPrior.config() returned.")
        for entry in config.get("measurements", []):
            unit = quantity_unit(space, str(entry["name"]))
            if entry.get("unit", unit) != unit:
                raise MeasurementError(f"the record measures {entry['name']} in {entry['unit']!r}, the space in "
                                       f"{unit!r}; convert it to {unit}.")
        measurements = tuple(Measurement(str(e["name"]), e["value"], e["sd"]) for e in config.get("measurements", []))
        return cls(space, measurements, {str(k): float(v) for k, v in config.get("fixed", {}).items()},
                   inert=tuple(str(n) for n in config.get("inert", ())))


def _describe(space: ParameterSpace, name: str) -> str:
    return space[name].description if name in space.names else QUANTITIES[name].description


def add_measurement_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--measured`` and ``--fix`` (read them with :func:`measurement_prior_from_args`)."""
    group = parser.add_argument_group("what you know (docs/identification.md)")
    group.add_argument("--measured", action="append", default=[], metavar="NAME=VALUE+-SD",
                       help="a measured quantity with its standard deviation, SI units: a parameter, rod_mass, "
                            "total_mass or rod_inertia, e.g. rod_mass=3.02+-0.05 or rod_length=1.74±0.002; repeatable")
    group.add_argument("--fix", action="append", default=[], metavar="NAME=VALUE",
                       help="hold a parameter at a known value (SI) and identify the others, e.g. "
                            "rod_length=1.74; repeatable")


def measurement_prior_from_args(args: argparse.Namespace, space: ParameterSpace) -> MeasurementPrior:
    """The :class:`MeasurementPrior` of ``--measured`` and ``--fix`` on the prior box ``space``, checked."""
    measurements = tuple(parse_measurement(text) for text in args.measured)
    pairs = [parse_fixed(text) for text in args.fix]
    check_measurements(space, measurements, pairs)
    return MeasurementPrior(space, measurements, dict(pairs))
