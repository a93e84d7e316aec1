"""Named physical parameters, their units and bounds, and the map to the unit cube.

A :class:`ParameterSpace` is an ordered set of :class:`Parameter`. A parameter vector θ travels as a
float array in that order (shape ``D`` or ``n x D``) or as an ``xarray.DataArray`` with a
``parameter`` dimension. The unit-cube map is affine per parameter::

    u = (θ - lower) / (upper - lower),     θ = lower + u (upper - lower)

Values of the 15 SUPERball parameters come from NTRT's T6 model (NASA-Tensegrity-Robotics-Toolkit/NTRTsim
``src/examples/SUPERball/T6Model.cpp`` at 4336712b), converted to SI; see docs/parameters.md for the table with sources.
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from dataclasses import replace as replace_fields

import numpy as np
import xarray as xr

from physics.errors import ParameterError

__all__ = ["Parameter", "ParameterSpace", "T6_NOMINAL"]


@dataclass(frozen=True)
class Parameter:
    """One physical parameter.

    ``lower``/``upper`` bound the search box; ``minimum`` is the physical limit (a value at or
    below it is non-physical, e.g. a zero density), ``strict`` says whether ``minimum`` itself is
    excluded.
    """

    name: str
    unit: str
    nominal: float
    lower: float
    upper: float
    description: str = ""
    minimum: float = 0.0
    strict: bool = True

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ParameterError(
                f"Parameter name {self.name!r} must be a Python identifier (letters, digits, _)."
            )
        for attr in ("nominal", "lower", "upper"):
            value = getattr(self, attr)
            if not np.isfinite(value):
                raise ParameterError(
                    f"Parameter {self.name!r}: {attr} must be a finite number, got {value!r}."
                )
        if not self.lower < self.upper:
            raise ParameterError(
                f"Parameter {self.name!r}: lower bound must be below upper bound, got "
                f"lower={self.lower!r}, upper={self.upper!r}. Swap or widen the bounds."
            )
        if not self._physical(self.lower):
            raise ParameterError(
                f"Parameter {self.name!r}: lower bound {self.lower!r} is non-physical "
                f"(must be {'>' if self.strict else '>='} {self.minimum!r} {self.unit}). "
                "Narrow the bounds."
            )

    def _physical(self, value: float) -> bool:
        return value > self.minimum if self.strict else value >= self.minimum


# name, unit, nominal, description  (SI; source: NTRT's T6Model.cpp, docs/parameters.md)
_T6_TABLE: tuple[tuple[str, str, float, str], ...] = (
    ("density", "kg/m^3", 311.0, "density of the two end segments of a rod"),
    ("radius", "m", 0.06, "radius of the end segments (also the contact radius)"),
    ("density_mp", "kg/m^3", 104.0, "density of the middle segment of a rod"),
    ("radius_mp", "m", 0.035, "radius of the middle segment of a rod"),
    ("rod_length", "m", 1.74, "node-to-node length of a rod"),
    ("rod_space", "m", 0.45, "distance of each rod from the centre plane"),
    ("rod_length_mp", "m", 1.0, "length of the middle segment of a rod"),
    ("stiffnessActive", "N/m", 800.0, "cable stiffness k"),
    ("damping", "N*s/m", 200.0, "cable damping c"),
    ("pretension", "N", 150.0, "cable tension at build time; sets the rest lengths"),
    ("maxTens", "N", 300.0, "tension limit of an actuated cable (stall torque = maxTens * r)"),
    ("targetVelocity", "m/s", 1.5, "no-load speed of rest-length change"),
    ("motor_radius", "m", 0.009, "spool radius r"),
    ("motor_friction", "N*m*s", 8.48e-5, "viscous motor friction b"),
    ("motor_inertia", "kg*m^2", 1.0996e-3, "motor plus spool inertia J"),
)

#: Nominal SI values of the 15 SUPERball parameters, by name.
T6_NOMINAL: Mapping[str, float] = {name: value for name, _, value, _ in _T6_TABLE}

# Parameters that may be zero (a model without damping or friction is still physical).
_T6_MAY_BE_ZERO = frozenset({"damping", "motor_friction"})


@dataclass(frozen=True)
class ParameterSpace:
    """An ordered set of named parameters with bounds: θ ∈ [lower, upper] ⊂ R^D.

    Build the SUPERball space with :meth:`t6`; any other with a sequence of :class:`Parameter`.
    """

    parameters: tuple[Parameter, ...]
    _index: dict[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        params = tuple(self.parameters)
        if not params:
            raise ParameterError("ParameterSpace needs at least one Parameter, got none.")
        if not all(isinstance(p, Parameter) for p in params):
            raise ParameterError("ParameterSpace.parameters must be a sequence of Parameter objects.")
        names = [p.name for p in params]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ParameterError(f"ParameterSpace has duplicate parameter names {dupes}; names must be unique.")
        object.__setattr__(self, "parameters", params)
        object.__setattr__(self, "_index", {n: i for i, n in enumerate(names)})

    # ------------------------------------------------------------------ construction
    @classmethod
    def t6(
        cls,
        *,
        relative_width: float = 0.10,
        bounds: Mapping[str, tuple[float, float]] | None = None,
        nominal: Mapping[str, float] | None = None,
    ) -> ParameterSpace:
        """The 15 SUPERball parameters with bounds nominal·(1 ± relative_width).

        ``bounds`` overrides the box of single parameters (SI), ``nominal`` their nominal values.
        """
        if not (0.0 < relative_width < 1.0):
            raise ParameterError(
                f"relative_width must lie in (0, 1), got {relative_width!r}; 0.1 means ±10 %."
            )
        bounds = dict(bounds or {})
        nominal = dict(nominal or {})
        unknown = sorted((set(bounds) | set(nominal)) - set(T6_NOMINAL))
        if unknown:
            raise ParameterError(
                f"Unknown T6 parameter name(s) {unknown}; valid names are {list(T6_NOMINAL)}."
            )
        params = []
        for name, unit, value, text in _T6_TABLE:
            value = float(nominal.get(name, value))
            lo, hi = bounds.get(name, (value * (1 - relative_width), value * (1 + relative_width)))
            params.append(
                Parameter(
                    name, unit, value, float(lo), float(hi), text,
                    minimum=0.0, strict=name not in _T6_MAY_BE_ZERO,
                )
            )
        return cls(tuple(params))

    # ------------------------------------------------------------------ properties
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def units(self) -> tuple[str, ...]:
        return tuple(p.unit for p in self.parameters)

    @property
    def dim(self) -> int:
        return len(self.parameters)

    def __len__(self) -> int:
        return len(self.parameters)

    def __iter__(self) -> Iterator[Parameter]:
        return iter(self.parameters)

    def __getitem__(self, name: str) -> Parameter:
        return self.parameters[self.index(name)]

    def index(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise ParameterError(f"Unknown parameter {name!r}; valid names are {list(self.names)}.") from None

    @property
    def nominal(self) -> np.ndarray:
        """Nominal θ, shape ``D``."""
        return np.array([p.nominal for p in self.parameters])

    @property
    def lower(self) -> np.ndarray:
        return np.array([p.lower for p in self.parameters])

    @property
    def upper(self) -> np.ndarray:
        return np.array([p.upper for p in self.parameters])

    # ------------------------------------------------------------------ conversion
    def as_array(self, theta: np.ndarray | Sequence[float] | Mapping[str, float] | xr.DataArray | None = None,
                 *, check_bounds: bool = True) -> np.ndarray:
        """θ as a validated float array of shape ``D`` or ``n x D``.

        Accepts an array, a mapping name -> value (missing names take the nominal value), an
        ``xarray.DataArray`` with a ``parameter`` dimension, or ``None`` (nominal). Raises
        :class:`ParameterError` for NaN, wrong length, non-physical values and, if
        ``check_bounds``, values outside [lower, upper].
        """
        if theta is None:
            return self.nominal
        if isinstance(theta, xr.DataArray):
            if "parameter" not in theta.dims:
                raise ParameterError(
                    f"theta DataArray needs a 'parameter' dimension, got dims {theta.dims}."
                )
            if "parameter" in theta.coords:
                names = [str(n) for n in theta["parameter"].values]
                missing = sorted(set(self.names) - set(names))
                if missing:
                    raise ParameterError(f"theta DataArray lacks parameter(s) {missing}.")
                theta = theta.sel(parameter=list(self.names))
            theta = theta.transpose(..., "parameter").values
        elif isinstance(theta, Mapping):
            unknown = sorted(set(theta) - set(self.names))
            if unknown:
                raise ParameterError(f"Unknown parameter name(s) {unknown}; valid names are {list(self.names)}.")
            theta = np.array([float(theta.get(n, p.nominal)) for n, p in zip(self.names, self.parameters, strict=True)])
        try:
            arr = np.asarray(theta, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"theta must be numeric, got {type(theta).__name__}: {exc}") from None
        if arr.ndim not in (1, 2) or arr.shape[-1] != self.dim:
            raise ParameterError(
                f"theta must have shape ({self.dim},) or (n, {self.dim}) in the order {list(self.names)}, "
                f"got shape {arr.shape}."
            )
        self._validate(arr, check_bounds=check_bounds)
        return arr

    def _validate(self, arr: np.ndarray, *, check_bounds: bool) -> None:
        rows = arr.reshape(-1, self.dim)
        for j, p in enumerate(self.parameters):
            col = rows[:, j]
            if not np.all(np.isfinite(col)):
                raise ParameterError(f"Parameter {p.name!r} is NaN or infinite; give a finite value in {p.unit}.")
            bad = col <= p.minimum if p.strict else col < p.minimum
            if np.any(bad):
                raise ParameterError(
                    f"Parameter {p.name!r} = {float(col[bad][0])!r} {p.unit} is non-physical: it must be "
                    f"{'>' if p.strict else '>='} {p.minimum!r}."
                )
            if check_bounds:
                tol = 1e-12 * (p.upper - p.lower)
                out = (col < p.lower - tol) | (col > p.upper + tol)
                if np.any(out):
                    raise ParameterError(
                        f"Parameter {p.name!r} = {float(col[out][0])!r} {p.unit} lies outside its bounds "
                        f"[{p.lower!r}, {p.upper!r}]; clip it, or widen the bounds "
                        "(ParameterSpace.t6(bounds=...)), or pass check_bounds=False."
                    )

    def as_dict(self, theta: np.ndarray | Mapping[str, float] | None = None, *,
                check_bounds: bool = False) -> dict[str, float]:
        """A single θ as a dict name -> SI value."""
        arr = self.as_array(theta, check_bounds=check_bounds)
        if arr.ndim != 1:
            raise ParameterError(f"as_dict takes a single theta of shape ({self.dim},), got {arr.shape}.")
        return {n: float(v) for n, v in zip(self.names, arr, strict=True)}

    def to_unit(self, theta: np.ndarray | Mapping[str, float]) -> np.ndarray:
        """u = (θ - lower) / (upper - lower); shape ``D`` or ``n x D``, inside [0, 1]."""
        arr = self.as_array(theta)
        return (arr - self.lower) / (self.upper - self.lower)

    def from_unit(self, u: np.ndarray | Sequence[float]) -> np.ndarray:
        """θ = lower + u (upper - lower) for u in [0, 1]^D; shape ``D`` or ``n x D``."""
        arr = np.asarray(u, dtype=float)
        if arr.ndim not in (1, 2) or arr.shape[-1] != self.dim:
            raise ParameterError(f"u must have shape ({self.dim},) or (n, {self.dim}), got {arr.shape}.")
        if not np.all(np.isfinite(arr)):
            raise ParameterError("u contains NaN or infinite values; unit-cube coordinates must be finite.")
        if np.any(arr < -1e-12) or np.any(arr > 1 + 1e-12):
            raise ParameterError(
                f"u must lie in the unit cube [0, 1]^{self.dim}, got values in "
                f"[{float(arr.min())!r}, {float(arr.max())!r}]; "
                "clip with numpy.clip(u, 0, 1)."
            )
        return self.lower + np.clip(arr, 0.0, 1.0) * (self.upper - self.lower)

    def to_dataarray(self, theta: np.ndarray | Mapping[str, float], *, check_bounds: bool = False) -> xr.DataArray:
        """θ as a DataArray with dimension ``parameter`` (and ``sample`` for n x D)."""
        arr = self.as_array(theta, check_bounds=check_bounds)
        dims = ("parameter",) if arr.ndim == 1 else ("sample", "parameter")
        return xr.DataArray(
            arr, dims=dims,
            coords={"parameter": list(self.names), "unit": ("parameter", list(self.units))},
        )

    def same_box(self, other: ParameterSpace) -> bool:
        """True when ``other`` has the same parameter names in the same order and the same bounds (to
        floating-point tolerance): θ vectors, decoders and journals of one are valid for the other."""
        return tuple(self.names) == tuple(other.names) and bool(
            np.allclose(self.lower, other.lower) and np.allclose(self.upper, other.upper))

    def with_overrides(self, *, nominal: Mapping[str, float] | None = None,
                       bounds: Mapping[str, tuple[float, float]] | None = None) -> ParameterSpace:
        """This space with some parameters' nominal values and boxes replaced by name (SI), e.g. for a
        robot built differently from the one the defaults describe.

        A new ``nominal`` alone recentres the box keeping its relative half-widths (±10 % stays ±10 %;
        a parameter whose nominal is 0, or whose sign would flip, is shifted instead); ``bounds`` alone
        keep the nominal when it lies inside them, else the nominal becomes their midpoint; both
        together must have lower <= nominal <= upper. Raises :class:`ParameterError` for an unknown
        name, lower >= upper, a nominal outside its bounds or a non-physical value."""
        nominal, bounds = dict(nominal or {}), dict(bounds or {})
        unknown = sorted((set(nominal) | set(bounds)) - set(self.names))
        if unknown:
            raise ParameterError(f"unknown parameter(s) {unknown}; the known names are {', '.join(self.names)}.")
        return ParameterSpace(tuple(_overridden(p, nominal.get(p.name), bounds.get(p.name))
                                    for p in self.parameters))

    def replace(self, theta: np.ndarray | Mapping[str, float] | None = None, **values: float) -> np.ndarray:
        """θ with some parameters replaced by name (bounds not checked), e.g. ``replace(damping=0.0)``."""
        arr = self.as_array(theta, check_bounds=False).copy()
        for name, value in values.items():
            arr[..., self.index(name)] = float(value)
        self._validate(arr, check_bounds=False)
        return arr

    def sample(self, n: int, *, seed: int | np.random.Generator) -> np.ndarray:
        """n points uniform in the box, shape ``n x D``."""
        if int(n) < 1:
            raise ParameterError(f"n must be a positive integer, got {n!r}.")
        rng = np.random.default_rng(seed)
        return self.from_unit(rng.random((int(n), self.dim)))

    @classmethod
    def from_parameters(cls, params: Iterable[Parameter]) -> ParameterSpace:
        return cls(tuple(params))


def _overridden(p: Parameter, nominal: float | None, bounds: tuple[float, float] | None) -> Parameter:
    """``p`` with a new nominal and/or box (:meth:`ParameterSpace.with_overrides`)."""
    if nominal is None and bounds is None:
        return p
    if nominal is not None:
        nominal = float(nominal)
        if not np.isfinite(nominal) or not p._physical(nominal):
            raise ParameterError(f"{p.name}: nominal {nominal!r} {p.unit} is not a physical value (it must be "
                                 f"{'>' if p.strict else '>='} {p.minimum!r}); give a finite value in SI units.")
    if bounds is not None:
        lo, hi = (float(v) for v in bounds)
        if not (np.isfinite(lo) and np.isfinite(hi)):
            raise ParameterError(f"{p.name}: bounds must be finite numbers in {p.unit}, got {lo!r}:{hi!r}.")
        if not lo < hi:
            raise ParameterError(f"{p.name}: lower bound {lo!r} must be below upper bound {hi!r} {p.unit}; "
                                 "swap them.")
        if nominal is None:
            nominal = p.nominal if lo <= p.nominal <= hi else 0.5 * (lo + hi)
        elif not lo <= nominal <= hi:
            raise ParameterError(f"{p.name}: nominal {nominal!r} lies outside its bounds [{lo!r}, {hi!r}] {p.unit}; "
                                 "give a nominal inside the bounds or widen them.")
    else:
        assert nominal is not None
        ratio = nominal / p.nominal if p.nominal != 0 else 0.0
        lo, hi = ((p.lower * ratio, p.upper * ratio) if ratio > 0
                  else (p.lower + nominal - p.nominal, p.upper + nominal - p.nominal))
        if not p._physical(lo):
            raise ParameterError(f"{p.name}: recentring the box on nominal {nominal!r} gives the non-physical lower "
                                 f"bound {lo!r} {p.unit}; give this parameter's bounds too.")
    return replace_fields(p, nominal=nominal, lower=lo, upper=hi)
