"""The mass-scale symmetry: what no trajectory can tell about masses and forces.

Newton's law m ẍ = F(x, ẋ) keeps its solutions x(t) when every mass and every force is multiplied
by the same λ > 0: gravity enters as an acceleration (the weight λ m g), DART's rigid contacts
and Coulomb friction are homogeneous in force, a cable's tension k (L − L0) + c L̇ scales with k
and c. So the trajectory of the T6 at θ and at

    θ'_j = λ^{p_j} θ_j,      p_j = the mass dimension of parameter j's unit

(kg/m³, N/m, N·s/m, N, N·m·s, kg·m² have p = 1; m, s, m/s, rad and 1 have p = 0) is the same, to
rounding: the symmetry is exact. The model's two fixed constants with a mass in their unit, the
rods' axial spin damping [N·m·s] and the motor driver's speed gain K_v [N·m·s]
(:class:`~physics.model_options.ModelOptions`), are given for the nominal robot and applied times
its mass scale

    s(θ) = M_rods(θ) / M_rods(θ_nominal),    M_rods = 6 m_rod  (physics.geometry.rod_mass_properties)

(:func:`rod_mass_scale`), which is λ s(θ) at θ'. Held at fixed values instead, they would tell the
data the absolute mass, a scale the real robot does not show (``benchmarks/identifiability.py``
measures how much; :func:`scale_options` builds such options). An effect's point mass is left
out of s: it scales with λ itself (unit kg), so the symmetry holds either way, and left out it only
adds mass, as the effect says. Trajectory data therefore pin ratios such as k/m, not the absolute
masses and forces; a weighed robot supplies the missing scale::

    λ = M_weighed / M(θ),       M(θ) = 6 m_rod(θ) (+ point_mass)          [kg]

and :func:`weighed` moves any θ to the equivalent one with the weighed mass.
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from physics.errors import ParameterError
from physics.geometry import rod_mass_properties
from physics.parameters import T6_NOMINAL, ParameterSpace

if TYPE_CHECKING:       # only for a hint: importing it would load the motor kernels (numba), which belief avoids
    from physics.model_options import ModelOptions

__all__ = ["MASS_DIMENSION", "mass_dimension", "mass_exponents", "robot_mass", "rod_mass_scale", "scale_masses",
           "scale_options", "weighed"]

#: mass dimension of each base unit the parameter tables use (N = kg·m/s²)
MASS_DIMENSION: Mapping[str, int] = {"kg": 1, "N": 1, "m": 0, "s": 0, "rad": 0, "1": 0}

#: the T6 parameters of a rod's mass, in physics.geometry.rod_mass_properties' order
_ROD = ("density", "radius", "density_mp", "radius_mp", "rod_length", "rod_length_mp")
_NOMINAL_ROD_MASS = rod_mass_properties(*(T6_NOMINAL[n] for n in _ROD)).mass     # [kg], the T6 default space's
_FACTOR = re.compile(r"^([A-Za-z]+|1)(?:\^(-?\d+))?$")


def mass_dimension(unit: str) -> int:
    """Exponent of kg in ``unit`` ("num*num/den*den", factors ``base`` or ``base^n``): "N*s/m" -> 1,
    "kg*m^2" -> 1, "1/m" -> 0. Raises :class:`ParameterError` for a unit it cannot read."""
    parts = unit.replace(" ", "").split("/")
    if len(parts) > 2 or not all(parts):
        raise ParameterError(f"unit {unit!r} is not of the form 'a*b/c*d'; write e.g. 'N*s/m' or 'kg/m^3'.")
    total = 0
    for sign, part in zip((1, -1), parts, strict=False):      # a unit without "/" has no denominator
        for factor in part.split("*"):
            match = _FACTOR.match(factor)
            if match is None or match.group(1) not in MASS_DIMENSION:
                raise ParameterError(f"unit {unit!r}: factor {factor!r} is not one of the base units "
                                     f"{sorted(MASS_DIMENSION)} (with an optional ^n); write the unit in SI.")
            total += sign * MASS_DIMENSION[match.group(1)] * int(match.group(2) or 1)
    return total


def mass_exponents(space: ParameterSpace) -> np.ndarray:
    """p_j of each parameter of ``space`` (shape ``D``, int)."""
    return np.array([mass_dimension(p.unit) for p in space], dtype=int)


def scale_masses(space: ParameterSpace, theta: np.ndarray, lam: float | np.ndarray) -> np.ndarray:
    """θ'_j = λ^{p_j} θ_j: the parameter vector(s) ``theta`` (``D`` or ``n x D``) with every mass and
    force multiplied by ``lam`` (a scalar, or one per row, shape ``n``), i.e. the same motion."""
    th = np.asarray(theta, dtype=float)
    lam_arr = np.asarray(lam, dtype=float)
    if not np.all(np.isfinite(lam_arr)) or np.any(lam_arr <= 0):
        raise ParameterError(f"the mass scale λ must be finite and > 0, got {lam!r}.")
    if th.shape[-1] != space.dim:
        raise ParameterError(f"theta has {th.shape[-1]} values per row, the space {space.dim} ({space.names}).")
    if lam_arr.ndim == 1:
        lam_arr = lam_arr[:, None]
    return th * lam_arr ** mass_exponents(space)


def scale_options(options: ModelOptions, lam: float) -> ModelOptions:
    """``options`` with its constants of mass dimension 1 times ``lam``: the spin damping and the motor
    driver's speed gain K_v.

    A model applies them times its mass scale (:func:`rod_mass_scale`), so θ scaled by
    :func:`scale_masses` needs no change of options to move the same. Use this to hold the applied
    constants at their absolute values instead: at ``scale_masses(space, θ, λ)`` with
    ``scale_options(options, 1 / λ)`` the model applies the spin damping and K_v it applies at θ, the
    model in which those constants show the data the robot's mass."""
    if not (np.isfinite(lam) and lam > 0):
        raise ParameterError(f"the mass scale λ must be finite and > 0, got {lam!r}.")
    motor = replace(options.motor, kv=options.motor.kv * lam)
    return replace(options, spin_damping=options.spin_damping * lam, motor=motor)


def rod_mass_scale(params: Mapping[str, float]) -> float:
    """s(θ) = M_rods(θ) / M_rods(θ_nominal), M_rods = 6 m_rod, m_rod from
    physics.geometry.rod_mass_properties at the T6 parameters ``params`` (by name; others ignored)
    and at the T6 nominal θ: the factor by which a model multiplies its constants of mass dimension
    1 (ModelOptions.spin_damping_at, motor_at). s(θ') = λ s(θ) at θ' = scale_masses(θ, λ); an
    effect's point masses are not in it (see the module docstring). Dimensionless."""
    missing = [n for n in _ROD if n not in params]
    if missing:
        raise ParameterError(f"rod_mass_scale needs the T6 rod parameters; params lack {missing}.")
    rod = rod_mass_properties(*(float(params[n]) for n in _ROD))
    return rod.mass / _NOMINAL_ROD_MASS


def robot_mass(space: ParameterSpace, theta: np.ndarray) -> np.ndarray:
    """M(θ) = 6 m_rod + point_mass [kg] of each row of ``theta`` (``D`` -> scalar array, ``n x D`` -> ``n``),
    m_rod from physics.geometry.rod_mass_properties."""
    th = np.atleast_2d(np.asarray(theta, dtype=float))
    missing = [n for n in _ROD if n not in space.names]
    if missing:
        raise ParameterError(f"robot_mass needs the T6 rod parameters; the space lacks {missing}.")
    index = {n: j for j, n in enumerate(space.names)}
    masses = []
    for row in th:
        rod = rod_mass_properties(*(row[index[n]] for n in _ROD))
        extra = row[index["point_mass"]] if "point_mass" in index else 0.0
        masses.append(6.0 * rod.mass + extra)
    out = np.array(masses)
    return out[0] if np.ndim(theta) == 1 else out


def weighed(space: ParameterSpace, theta: np.ndarray, mass: float) -> np.ndarray:
    """θ (``D`` or ``n x D``) moved along the symmetry to the weighed robot mass ``mass`` [kg]:
    scale_masses(θ, mass / M(θ))."""
    if not (np.isfinite(mass) and mass > 0):
        raise ParameterError(f"the weighed mass must be a positive number of kg, got {mass!r}.")
    return scale_masses(space, theta, mass / robot_mass(space, theta))
