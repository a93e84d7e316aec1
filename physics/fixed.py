"""Parameters the user fixes: an objective over the others, with the fixed values put back in.

A researcher who knows a parameter well (a rod length read off a drawing, a friction measured on a
bench) takes it out of the search. With D parameters of which F are fixed to values c, the free
parameters θ_f (D − F,) map to the full vector by inserting c at the fixed positions::

    θ = insert(θ_f, c),      E_fixed(θ_f) = E(insert(θ_f, c))

:class:`FixedParameters` is that objective: its ``space`` is the objective's without the fixed
parameters (same bounds and nominal values for the others), and every member of the
:class:`~physics.objective.Objective` contract delegates with the values inserted, so belief sees
a D − F dimensional problem. Its fingerprint names the fixed values, so a journal of another
choice is refused. A fixed value must be physical and inside the objective's own box (the
objective may refuse θ outside it); :func:`physics.quantities.check_value` says what is wrong.
"""
from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable

import numpy as np

from physics.errors import MeasurementError, ParameterError
from physics.objective import BatchResult, Objective, ObjectiveFunction, OnResult, as_objective
from physics.parameters import ParameterSpace
from physics.quantities import check_value

__all__ = ["FixedParameters", "check_fixed", "free_space", "insert_fixed", "free_values"]


def check_fixed(space: ParameterSpace, fixed: Mapping[str, float]) -> dict[str, float]:
    """``fixed`` as name -> float in the order of ``space.names``, each value checked by
    :func:`~physics.quantities.check_value`; at least one parameter must stay free."""
    values = {str(name): float(value) for name, value in fixed.items()}
    for name, value in values.items():
        check_value(space, name, value, role="fixed")
    if len(values) >= space.dim:
        raise MeasurementError(f"every parameter of the space is fixed ({', '.join(space.names)}): nothing is left "
                               "to identify; fix fewer parameters.")
    return {name: values[name] for name in space.names if name in values}


def free_space(space: ParameterSpace, fixed: Mapping[str, float]) -> ParameterSpace:
    """``space`` without the parameters named in ``fixed`` (the others unchanged, in their order)."""
    unknown = sorted(set(fixed) - set(space.names))
    if unknown:
        raise MeasurementError(f"fixed {unknown}: unknown parameter(s); the parameters are {', '.join(space.names)}.")
    return ParameterSpace.from_parameters(p for p in space if p.name not in fixed)


def insert_fixed(space: ParameterSpace, fixed: Mapping[str, float], thetas: np.ndarray) -> np.ndarray:
    """Full θ (``D`` or ``n x D``, order of ``space.names``) from free rows θ_f (``D − F`` or ``n x (D − F)``,
    the order of :func:`free_space`) with ``fixed`` inserted; bounds are the objective's to check."""
    arr = np.asarray(thetas, dtype=float)
    free = [j for j, name in enumerate(space.names) if name not in fixed]
    if arr.ndim not in (1, 2) or arr.shape[-1] != len(free):
        names = [space.names[j] for j in free]
        raise ParameterError(f"θ of the free parameters must have shape ({len(free)},) or (n, {len(free)}) in the "
                             f"order {names}, got {arr.shape}; leave the fixed ones {sorted(fixed)} out.")
    full = np.empty((*arr.shape[:-1], space.dim))
    full[..., free] = arr
    for name, value in fixed.items():
        full[..., space.index(name)] = value
    return full


def free_values(space: ParameterSpace, fixed: Mapping[str, float], thetas: np.ndarray) -> np.ndarray:
    """The free parameters (``D − F`` or ``n x (D − F)``) of full rows θ (``D`` or ``n x D``, order of ``space``)."""
    arr = np.asarray(thetas, dtype=float)
    if arr.ndim not in (1, 2) or arr.shape[-1] != space.dim:
        raise ParameterError(f"a full θ has shape ({space.dim},) or (n, {space.dim}) in the order {list(space.names)}, "
                             f"got {arr.shape}.")
    return arr[..., [j for j, name in enumerate(space.names) if name not in fixed]]


@runtime_checkable
class _Closable(Protocol):
    def close(self) -> None: ...


class FixedParameters:
    """The :class:`~physics.objective.Objective` ``objective`` with the parameters in ``fixed`` (name ->
    SI value) held at those values: θ (D − F,) in ``space`` (module docstring).

    Attributes: ``objective`` (the wrapped one), ``full_space`` (its space), ``space`` (the free
    parameters), ``fixed`` (read-only name -> value). Raises :class:`MeasurementError` for an unknown,
    non-physical or out-of-box value, or when every parameter is fixed.
    """

    def __init__(self, objective: Objective | ObjectiveFunction, fixed: Mapping[str, float]) -> None:
        self.objective = as_objective(objective)
        self.full_space = self.objective.space
        self.fixed: Mapping[str, float] = MappingProxyType(check_fixed(self.full_space, fixed))
        self.space = free_space(self.full_space, self.fixed)

    def full(self, theta: np.ndarray) -> np.ndarray:
        """θ of the wrapped objective (``D`` or ``n x D``) from free θ (``D − F`` or ``n x (D − F)``)."""
        return insert_fixed(self.full_space, self.fixed, theta)

    def free(self, theta: np.ndarray) -> np.ndarray:
        """The free parameters (``D − F`` or ``n x (D − F)``) of a full θ (``D`` or ``n x D``)."""
        return free_values(self.full_space, self.fixed, theta)

    @property
    def segments(self) -> tuple[str, ...]:
        """The wrapped objective's segments."""
        return self.objective.segments

    @property
    def n_observations(self) -> int:
        """K of the wrapped objective."""
        return self.objective.n_observations

    @property
    def noise_var(self) -> float | None:
        """σ² of the wrapped objective (units of E), or None."""
        return self.objective.noise_var

    @property
    def noise_floor(self) -> float | None:
        """s₀² of the wrapped objective (units of E per residual), or None."""
        return self.objective.noise_floor

    def __call__(self, theta: np.ndarray) -> float:
        """E(insert(θ_f, c)) for free θ_f (D − F,)."""
        return self.objective(self.full(theta))

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        """Parts (S,) of the wrapped objective at insert(θ_f, c)."""
        return self.objective.evaluate_parts(self.full(theta))

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: OnResult | None = None) -> BatchResult:
        """The wrapped objective's batch at the rows of θ_f (n, D − F) with c inserted; rows in input order."""
        return self.objective.evaluate_batch(self.full(np.atleast_2d(thetas)), on_result=on_result)

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        """The wrapped objective's residuals (S arrays (T_s, m)) at insert(θ_f, c)."""
        return self.objective.residuals(self.full(theta))

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        """The wrapped objective's residuals at each row of θ_f (n, D − F), None where not ok."""
        return self.objective.residuals_batch(self.full(np.atleast_2d(thetas)))

    def fingerprint(self) -> dict[str, Any]:
        """The wrapped objective's fingerprint, the fixed values and the free parameters, with ``segments``."""
        return {"kind": "fixed parameters", "objective": self.objective.fingerprint(), "fixed": dict(self.fixed),
                "parameters": list(self.space.names), "segments": list(self.segments)}

    def close(self) -> None:
        """Close the wrapped objective when it has workers to release (``close()``)."""
        if isinstance(self.objective, _Closable):
            self.objective.close()

    def __enter__(self) -> FixedParameters:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        values = ", ".join(f"{name}={value:g}" for name, value in self.fixed.items())
        return f"FixedParameters({type(self.objective).__name__}, {values}; D={self.space.dim})"
