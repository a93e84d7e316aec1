"""Quantities a researcher can measure on the robot, as functions g(θ) of the parameters.

Each quantity maps rows θ (``n x D``, in the order of ``space.names``; a single θ ``D`` counts as
one row) to values ``(n,)`` in SI units::

    rod_mass     m_rod = 2 ρ π r² l_e + ρ_mp π r_mp² l_mp,  l_e = (L − l_mp)/2        [kg]
    total_mass   M = 6 m_rod (+ point_mass when the space has it)                     [kg]
    rod_inertia  I = 2 [m_e (3r² + l_e²)/12 + m_e d²] + m_mp (3 r_mp² + l_mp²)/12       [kg·m²]
                 (one rod about a transverse axis through its centre, d = (l_mp + l_e)/2)
    NAME         θ_NAME, any parameter of the space, in its own unit

from :func:`physics.geometry.rod_mass_properties` (three coaxial solid cylinders); ``total_mass``
is :func:`physics.scaling.robot_mass`, the mass a scale reads. A parameter of the space wins over a
derived quantity of the same name.

:func:`quantity_range` is the range [g_min, g_max] the prior box allows for a quantity: g at the
corners of the box of the parameters it depends on and at 256 Sobol points between them
(``scipy.stats.qmc``, unscrambled, so the same box gives the same range), the others at their
nominal values. It is exact for quantities monotone in each parameter (the masses) and a close
inner estimate otherwise. :func:`check_value` uses it to refuse what the box cannot produce, and
calls a value more than :data:`UNIT_SLIP` times outside it a unit slip (grams for kilograms),
:func:`unit_slip`, the rule the prior box's options share (physics.prior_box).
"""
from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Literal

import numpy as np

from physics.errors import MeasurementError, ParameterError
from physics.geometry import RodMassProperties, rod_mass_properties
from physics.parameters import ParameterSpace

__all__ = ["Quantity", "QUANTITIES", "UNIT_SLIP", "rod_mass", "total_mass", "rod_inertia", "known_quantities",
           "quantity_unit", "depends_on", "measured_values", "quantity_range", "check_value",
           "unit_text", "UnitSlip", "unit_slip"]

#: A value more than this factor above the box's range (or below it) is reported as a unit slip.
UNIT_SLIP = 20.0

#: The T6 parameters of one rod, in the order of physics.geometry.rod_mass_properties.
_ROD = ("density", "radius", "density_mp", "radius_mp", "rod_length", "rod_length_mp")

#: unit -> (factor, the unit a slip by that factor suggests): a value given in the second is factor times the SI one.
_SLIPS: Mapping[str, tuple[tuple[float, str], ...]] = {
    "kg": ((1e3, "grams"),),
    "m": ((1e3, "millimetres"), (1e2, "centimetres")),
    "kg*m^2": ((1e4, "kg*cm^2"), (1e6, "kg*mm^2"), (1e7, "g*cm^2"), (1e9, "g*mm^2")),
    "kg/m^3": ((1e-3, "g/cm^3"),),
}


def _rows(space: ParameterSpace, thetas: np.ndarray) -> np.ndarray:
    """θ as validated rows ``n x D`` (bounds not checked: a measurement may be compared anywhere)."""
    return np.atleast_2d(space.as_array(thetas, check_bounds=False))


def _rods(space: ParameterSpace, thetas: np.ndarray) -> list[RodMassProperties]:
    """The mass properties of one rod at each row of ``thetas`` (``n x D``)."""
    missing = [name for name in _ROD if name not in space.names]
    if missing:
        raise MeasurementError(f"rod quantities need the T6 rod parameters {list(_ROD)}; the space lacks {missing}. "
                               "Measure a parameter of the space instead.")
    cols = [space.index(name) for name in _ROD]
    return [rod_mass_properties(*(float(v) for v in row[cols])) for row in _rows(space, thetas)]


def rod_mass(space: ParameterSpace, thetas: np.ndarray) -> np.ndarray:
    """m_rod [kg] of one rod (two end cylinders and the middle one) at each row: ``n x D`` -> ``(n,)``."""
    return np.array([rod.mass for rod in _rods(space, thetas)], dtype=float)


def rod_inertia(space: ParameterSpace, thetas: np.ndarray) -> np.ndarray:
    """I_trans [kg·m²] of one rod about a transverse axis through its centre: ``n x D`` -> ``(n,)``."""
    return np.array([rod.transverse for rod in _rods(space, thetas)], dtype=float)


def total_mass(space: ParameterSpace, thetas: np.ndarray) -> np.ndarray:
    """M = 6 m_rod + point_mass [kg] (point_mass when the space has it): ``n x D`` -> ``(n,)``."""
    mass = 6.0 * rod_mass(space, thetas)
    if "point_mass" in space.names:
        mass = mass + _rows(space, thetas)[:, space.index("point_mass")]
    return mass


#: g(space, θ rows n x D) -> (n,)
QuantityFunction = Callable[[ParameterSpace, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Quantity:
    """A derived quantity: its SI ``unit``, ``function`` g(space, θ (n x D)) -> (n,), a ``description``,
    the parameters it ``needs`` and those it uses when the space has them (``optional``)."""

    unit: str
    function: QuantityFunction
    description: str
    needs: tuple[str, ...]
    optional: tuple[str, ...] = ()


#: name -> the derived quantities a user can measure (module docstring); every parameter name is one too.
QUANTITIES: Mapping[str, Quantity] = MappingProxyType({
    "rod_mass": Quantity("kg", rod_mass, "mass of one rod", _ROD),
    "total_mass": Quantity("kg", total_mass, "mass of the robot: 6 rods (and point_mass)", _ROD, ("point_mass",)),
    "rod_inertia": Quantity("kg*m^2", rod_inertia, "moment of inertia of one rod about a transverse axis "
                                                    "through its centre", _ROD),
})


def known_quantities(space: ParameterSpace) -> tuple[str, ...]:
    """What can be measured on ``space``: the derived quantities whose parameters it has, then its parameters."""
    derived = [name for name, q in QUANTITIES.items()
               if name not in space.names and all(n in space.names for n in q.needs)]
    return (*derived, *space.names)


def _derived(space: ParameterSpace, name: str) -> Quantity | None:
    """The derived quantity ``name`` when it is one on ``space`` (a parameter wins), else None; unknown raises."""
    if name in space.names:
        return None
    if name not in known_quantities(space):
        raise MeasurementError(f"unknown quantity {name!r}; the known ones are {', '.join(known_quantities(space))}.")
    return QUANTITIES[name]


def quantity_unit(space: ParameterSpace, name: str) -> str:
    """The SI unit of quantity ``name`` on ``space``."""
    quantity = _derived(space, name)
    return space[name].unit if quantity is None else quantity.unit


def depends_on(space: ParameterSpace, name: str) -> tuple[str, ...]:
    """The parameters of ``space`` that quantity ``name`` depends on (``(name,)`` for a parameter)."""
    quantity = _derived(space, name)
    if quantity is None:
        return (name,)
    return tuple(n for n in space.names if n in quantity.needs or n in quantity.optional)


def measured_values(space: ParameterSpace, thetas: np.ndarray, name: str) -> np.ndarray:
    """g_name(θ) at each row of ``thetas`` (``n x D`` or ``D``) -> ``(n,)`` in :func:`quantity_unit`."""
    quantity = _derived(space, name)
    if quantity is None:
        return _rows(space, thetas)[:, space.index(name)].astype(float)
    return quantity.function(space, thetas)


def _box_points(space: ParameterSpace, names: tuple[str, ...]) -> np.ndarray:
    """The corners of the box of ``names`` and 256 unscrambled Sobol points in it, the other parameters
    at their nominal values: ``(2^k + 256) x D``."""
    from scipy.stats import qmc

    cols = [space.index(n) for n in names]
    corners = np.array(list(itertools.product((0.0, 1.0), repeat=len(cols))))
    inner = qmc.Sobol(len(cols), scramble=False).random(256)
    u = np.tile(space.to_unit(space.nominal), (len(corners) + len(inner), 1))
    u[:, cols] = np.vstack([corners, inner])
    return space.from_unit(np.clip(u, 0.0, 1.0))


@functools.lru_cache(maxsize=64)
def quantity_range(space: ParameterSpace, name: str) -> tuple[float, float]:
    """[g_min, g_max] of quantity ``name`` over the prior box (module docstring); a parameter's own bounds."""
    if _derived(space, name) is None:
        return space[name].lower, space[name].upper
    points = _box_points(space, depends_on(space, name))
    try:
        values = measured_values(space, points, name)
    except ParameterError:              # part of the box is no rod (rod_length_mp >= rod_length): drop it
        values = np.array([_or_nan(space, point, name) for point in points])
    values = values[np.isfinite(values)]
    if values.size == 0:
        raise MeasurementError(f"{name} is defined nowhere in the prior box (rod_length_mp >= rod_length "
                               "everywhere); narrow the box of rod_length_mp or rod_length with --bounds.")
    return float(values.min()), float(values.max())


def _or_nan(space: ParameterSpace, theta: np.ndarray, name: str) -> float:
    try:
        return float(measured_values(space, theta, name)[0])
    except ParameterError:
        return math.nan


def _physical(space: ParameterSpace, name: str, value: float) -> str | None:
    """Why ``value`` is impossible for quantity ``name`` (masses, lengths and inertias are > 0), or None."""
    if name in space.names:
        p = space[name]
        ok = value > p.minimum if p.strict else value >= p.minimum
        return None if ok else f"must be {'>' if p.strict else '>='} {p.minimum:g}{unit_text(p.unit)}"
    return None if value > 0 else f"must be > 0 {quantity_unit(space, name)}"


def unit_text(unit: str) -> str:
    """The unit as written after a number: ' kg', and nothing for a dimensionless one (unit "1" or "")."""
    return "" if unit in ("", "1") else f" {unit}"


def _times(ratio: float) -> str:
    """A factor rounded to two significant digits, written plainly: 296.4 -> '300', 1e6 -> '1e+06'."""
    return f"{float(f'{ratio:.2g}'):g}"


@dataclass(frozen=True)
class UnitSlip:
    """A value of a quantity more than :data:`UNIT_SLIP` times outside the range [``low``, ``high``]
    the prior box allows: ``ratio`` is the value over the quantity at the nominal θ, and when that
    ratio lies within half a decade of a common wrong unit (``_SLIPS``: 1000 for grams of a kg
    quantity), ``wrong`` names that unit and ``factor`` is the ratio it implies (value / factor is
    then the SI value meant); both None otherwise."""

    unit: str
    low: float
    high: float
    ratio: float
    factor: float | None
    wrong: str | None

    def clause(self) -> str:
        """"is 1000 times the box's range 1.52-5.23 kg: the unit is kg (did you give grams?)"."""
        size = f"{_times(self.ratio)} times" if self.ratio > 1 else f"1/{_times(1 / self.ratio)} of"
        hint = f" (did you give {self.wrong}?)" if self.wrong else "; give it in SI units"
        return (f"is {size} the box's range {self.low:.3g}-{self.high:.3g}{unit_text(self.unit)}: the unit is "
                f"{unit_text(self.unit).strip() or '1 (none)'}{hint}")


def unit_slip(space: ParameterSpace, name: str, value: float) -> UnitSlip | None:
    """The :class:`UnitSlip` of ``value`` for quantity ``name`` on ``space`` when it lies more than
    :data:`UNIT_SLIP` times above :func:`quantity_range` (or below it, for a positive value), else None.
    Shared by what the user measures or fixes (:func:`check_value`) and the prior box they set
    (physics.prior_box), so that both call a slip by the same rule."""
    lo, hi = quantity_range(space, name)
    if not (value > UNIT_SLIP * hi or 0 < value < lo / UNIT_SLIP):
        return None
    typical = _or_nan(space, space.nominal, name)
    ratio = value / (typical if typical > 0 else 0.5 * (lo + hi))
    unit = quantity_unit(space, name)
    near = [(abs(math.log10(ratio / factor)), factor, other) for factor, other in _SLIPS.get(unit, ())
            if abs(math.log10(ratio / factor)) < 0.5]
    _, factor, wrong = min(near) if near else (None, None, None)
    return UnitSlip(unit=unit, low=lo, high=hi, ratio=ratio, factor=factor, wrong=wrong)


def check_value(space: ParameterSpace, name: str, value: float, *, role: Literal["measured", "fixed"]) -> None:
    """Raise :class:`MeasurementError` (one line: the problem and the fix) unless ``value`` of quantity
    ``name`` is known, physical and inside :func:`quantity_range`; far outside (:data:`UNIT_SLIP` times)
    it is named a unit slip, with its ratio to the quantity at the nominal θ (1000: grams for kilograms).
    A ``"fixed"`` value must name a parameter of ``space``."""
    if role == "fixed" and name not in space.names:
        how = (f"{name} is derived from {', '.join(QUANTITIES[name].needs)}: measure it (--measured) or fix those"
               if name in QUANTITIES else f"the parameters are {', '.join(space.names)}")
        raise MeasurementError(f"fixed {name}: only a parameter can be fixed; {how}.")
    unit = quantity_unit(space, name)
    if not math.isfinite(value):
        raise MeasurementError(f"{role} {name}={value!r}: give a finite number in {unit}.")
    why = _physical(space, name, value)
    if why is not None:
        raise MeasurementError(f"{role} {name}={value:g}{unit_text(unit)} is impossible: it {why}; give a value in "
                               "SI units.")
    lo, hi = quantity_range(space, name)
    text, slip = f"{role} {name}={value:g}{unit_text(unit)}", unit_slip(space, name, value)
    if slip is not None:
        raise MeasurementError(f"{text} {slip.clause()}.")
    tol = 1e-9 * (hi - lo)
    if not lo - tol <= value <= hi + tol:
        params = depends_on(space, name)
        widen = (f"--bounds {name}=LO:HI or --nominal {name}=VALUE" if params == (name,)
                 else f"--bounds NAME=LO:HI or --nominal NAME=VALUE on {', '.join(params)}")
        raise MeasurementError(f"{text} lies outside the range {lo:.4g}-{hi:.4g}{unit_text(unit)} that the prior box "
                               f"allows; widen the box with {widen} (ParameterSpace.with_overrides), or check the "
                               "value.")
