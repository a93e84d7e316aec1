"""What the data pin: the identifiability map of a fit, from its Jacobian.

At a fitted θ̂ with residuals r (K,), their Jacobian J = ∂r/∂u (K x D) in the unit box
u = (θ − lower) / width (belief.least_squares.LocalStep.jacobian, taken at the step's start: pass
that point as θ̂), the likelihood's variance σ²
per residual and optional prior rows G (M x D, standardized residuals of measurements in the same
u, e.g. a weighed robot), the Fisher information in the unit box is

    F_u = JᵀJ / σ² + GᵀG                                                   (D x D)

(the Gauss-Newton Hessian of E / (2σ²) plus the prior's). It is read in relative changes,
x_j = log θ_j, so dx_j = width_j du_j / s_j with s_j = |θ̂_j| (a parameter at 0, such as an effect
that is off, is measured relative to its box instead: s_j = width_j), and F_x = T F_u T with
T = diag(s / width). Each eigenpair (λ_k, v_k) of F_x is a direction: moving θ by the relative
change t v_k (|v_k| = 1) raises −log-likelihood by λ_k t² / 2, so its 1-σ width is 1/√λ_k (a
fraction; reported in %; unbounded when λ_k is within eigh's rounding, D ε λ_max, of 0). A
direction is

- "pinned": width under ``pinned_pct`` (default 2 %);
- "weak": wider, but under the box's half extent along it, h(v) = 1 / √Σ_j (v_j / h_j)², with
  h_j = width_j / (2 s_j) the box's half width in x_j (the ellipsoid inscribed in the box);
- "free": as wide as the box or wider: the data add nothing the box did not say.

Symmetries are named as such. The mass–force scale (physics.scaling: every mass and force times
λ gives the same motion) moves x along p_j = (mass exponent of parameter j) x sign θ̂_j; with
p̂ = p / |p|, its information p̂ᵀ F_x p̂ is reported as a share of the largest eigenvalue: "exact"
when that share is at most :data:`SYMMETRY_RTOL` (finite differences and rounding leave no more),
"near" when 1 / √(p̂ᵀ F_x p̂) is beyond the box along p̂, "resolved" otherwise (a prior row or
something outside the symmetry pins it). Inert parameters are those whose column of J has a norm
at most :data:`INERT_RTOL` of the largest: the motions behind J do not move them.

Marginal widths per parameter are the 1-σ Laplace widths sqrt diag (F_u + τ I)⁻¹ x width [θ units]
with τ = 1e-12 x mean diag F_u (a ridge that only keeps the inverse finite), in % of |nominal| (of
the box width for a parameter whose nominal is 0).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from belief.errors import BeliefError
from physics.parameters import ParameterSpace
from physics.scaling import mass_exponents

__all__ = ["DirectionKind", "SymmetryStatus", "Direction", "Symmetry", "Identifiability", "identifiability",
           "direction_text", "SYMMETRY_RTOL", "INERT_RTOL", "MASS_FORCE"]

DirectionKind = Literal["pinned", "weak", "free"]
SymmetryStatus = Literal["exact", "near", "resolved"]
#: JSON values as :meth:`Identifiability.as_dict` writes them (inf as None)
JSONValue = float | int | str | bool | None | list["JSONValue"] | dict[str, "JSONValue"]

#: information along a symmetry at most this share of the largest eigenvalue: "exact"
SYMMETRY_RTOL = 1e-6
#: a column of J with norm at most this share of the largest: "inert"
INERT_RTOL = 1e-6
#: what the mass–force symmetry is called in reports
MASS_FORCE = "the mass–force scale (every mass and force times the same factor)"
_KINDS: dict[str, DirectionKind] = {"pinned": "pinned", "weak": "weak", "free": "free"}
_STATUSES: dict[str, SymmetryStatus] = {"exact": "exact", "near": "near", "resolved": "resolved"}
_RIDGE = 1e-12
_LOADING = 0.2          # loadings named in a direction's text: |v_j| >= this (the top 3 when none is)
_LABELLED = 0.9         # a direction with |v · p̂| >= this is labelled as the symmetry p̂


@dataclass(frozen=True)
class Direction:
    """One eigen-direction of F_x (module docstring): ``information`` λ_k [1 / relative change²],
    ``width_pct`` 100 / √λ_k (inf when λ_k <= 0), ``box_pct`` 100 h(v_k), ``loadings`` the unit vector
    v_k (D,) over the parameters in relative changes, signed so its largest entry is positive,
    ``text`` its largest loadings ("+0.55 density +0.50 rod_length_mp −0.49 maxTens"), ``kind``, and
    ``label`` the symmetry it lies along ("" if none)."""

    information: float
    width_pct: float
    box_pct: float
    loadings: tuple[float, ...]
    text: str
    kind: DirectionKind
    label: str = ""

    def __post_init__(self) -> None:
        if self.kind not in get_args(DirectionKind):
            raise BeliefError(f"Direction.kind must be one of {get_args(DirectionKind)}, got {self.kind!r}.")
        if not (self.width_pct > 0 and self.box_pct > 0) or not np.all(np.isfinite(self.loadings)):
            raise BeliefError(f"Direction needs widths > 0 and finite loadings, got width {self.width_pct!r} %, "
                              f"box {self.box_pct!r} %.")


@dataclass(frozen=True)
class Symmetry:
    """A direction the laws of the model leave unseen: ``name``, its unit vector ``loadings`` (D,) in
    relative changes, ``information`` p̂ᵀ F_x p̂, ``share`` of the largest eigenvalue, ``width_pct``
    100 / √information (inf at 0), ``box_pct`` 100 h(p̂), and ``status`` (module docstring)."""

    name: str
    loadings: tuple[float, ...]
    information: float
    share: float
    width_pct: float
    box_pct: float
    status: SymmetryStatus

    def __post_init__(self) -> None:
        if self.status not in get_args(SymmetryStatus):
            raise BeliefError(f"Symmetry.status must be one of {get_args(SymmetryStatus)}, got {self.status!r}.")

    def line(self) -> str:
        """One line saying whether the data see the symmetry."""
        if self.status == "resolved":
            return (f"symmetry: {self.name} is resolved: pinned to {_pm(self.width_pct)} "
                    f"(box {_pm(self.box_pct)}).")
        how = ("exact: the data carry " if self.status == "exact" else "near: the data carry only ")
        return (f"symmetry: {self.name} is {how}{self.share:.2g} of the largest information along it "
                f"(width {_pm(self.width_pct)}, box {_pm(self.box_pct)}); what lies along it is pinned only as "
                "ratios, a measurement of the scale fixes it (for masses: physics.scaling.weighed).")


@dataclass(frozen=True)
class Identifiability:
    """The identifiability map (module docstring): parameter ``names`` (D,), ``directions`` from best
    pinned to least, ``symmetries``, ``inert`` parameter names, ``marginal_pct`` (D,) 1-σ marginal
    widths in % of |nominal|, and the ``pinned_pct`` threshold used."""

    names: tuple[str, ...]
    directions: tuple[Direction, ...]
    symmetries: tuple[Symmetry, ...]
    inert: tuple[str, ...]
    marginal_pct: tuple[float, ...]
    pinned_pct: float = 2.0

    def __post_init__(self) -> None:
        d = len(self.names)
        if len(self.marginal_pct) != d or any(len(v.loadings) != d for v in self.directions) \
                or any(len(s.loadings) != d for s in self.symmetries):
            raise BeliefError(f"Identifiability: marginal widths and every direction need {d} entries, one per "
                              "name; build it with belief.identifiability(...).")
        if not set(self.inert) <= set(self.names):
            raise BeliefError(f"Identifiability.inert names {sorted(set(self.inert) - set(self.names))} "
                              "that are not parameters.")

    def information(self) -> np.ndarray:
        """F_x (D x D) in relative changes, rebuilt from the directions: Σ_k λ_k v_k v_kᵀ."""
        if not self.directions:
            return np.zeros((len(self.names), len(self.names)))
        V = np.array([v.loadings for v in self.directions]).T
        return (V * np.array([v.information for v in self.directions])) @ V.T

    def count(self, kind: DirectionKind) -> int:
        """How many directions are of ``kind``."""
        return sum(v.kind == kind for v in self.directions)

    def lines(self) -> list[str]:
        """The text of a summary's section "What the data pin", one line each."""
        out = [f"What the data pin: {len(self.directions)} directions in relative changes (d log θ) of "
               "F = JᵀJ/σ² + GᵀG, 1-σ width along each"]
        for k, v in enumerate(self.directions, 1):
            label = f"  ({v.label})" if v.label else ""
            out.append(f"  {k:2d}. {_pm(v.width_pct):>10s}  {v.kind:6s}  {v.text}{label}")
        out.append(f"  {self.count('pinned')} pinned (under {self.pinned_pct:g} %), {self.count('weak')} weak "
                   f"(under the box), {self.count('free')} free")
        out += [s.line() for s in self.symmetries]
        if self.inert:
            out.append(f"inert (these motions do not move it): {', '.join(self.inert)}")
        out.append("marginal widths (1 σ, % of nominal): "
                   + ", ".join(f"{n} {_pm(w)}" for n, w in zip(self.names, self.marginal_pct, strict=True)))
        return out

    def as_dict(self) -> dict[str, JSONValue]:
        """A JSON-able dict (infinite widths as None), read back by :meth:`from_dict`."""
        return {"names": list(self.names), "pinned_pct": self.pinned_pct, "inert": list(self.inert),
                "marginal_pct": [_out(w) for w in self.marginal_pct],
                "directions": [{"information": v.information, "width_pct": _out(v.width_pct),
                                "box_pct": _out(v.box_pct), "loadings": list(v.loadings), "text": v.text,
                                "kind": v.kind, "label": v.label} for v in self.directions],
                "symmetries": [{"name": s.name, "loadings": list(s.loadings), "information": s.information,
                                "share": s.share, "width_pct": _out(s.width_pct), "box_pct": _out(s.box_pct),
                                "status": s.status} for s in self.symmetries]}

    @classmethod
    def from_dict(cls, data: Mapping[str, JSONValue]) -> Identifiability:
        """The map :meth:`as_dict` wrote. Raises :class:`BeliefError` when a key is missing or mistyped."""
        directions = tuple(Direction(information=_float(v, "information"), width_pct=_float(v, "width_pct"),
                                     box_pct=_float(v, "box_pct"), loadings=_floats(v, "loadings"),
                                     text=_str(v, "text"), kind=_kind(_str(v, "kind")), label=_str(v, "label"))
                           for v in _records(data, "directions"))
        symmetries = tuple(Symmetry(name=_str(s, "name"), loadings=_floats(s, "loadings"),
                                    information=_float(s, "information"), share=_float(s, "share"),
                                    width_pct=_float(s, "width_pct"), box_pct=_float(s, "box_pct"),
                                    status=_status(_str(s, "status"))) for s in _records(data, "symmetries"))
        return cls(names=_strs(data, "names"), directions=directions, symmetries=symmetries,
                   inert=_strs(data, "inert"), marginal_pct=_floats(data, "marginal_pct"),
                   pinned_pct=_float(data, "pinned_pct"))


def identifiability(jacobian: np.ndarray, *, noise_var: float, space: ParameterSpace, theta: np.ndarray,
                    width: np.ndarray, prior_rows: np.ndarray | None = None, pinned_pct: float = 2.0
                    ) -> Identifiability:
    """The identifiability map at θ̂ = ``theta`` (D,) from the residuals' Jacobian (K x D) in the unit
    box of box widths ``width`` (D,) = upper − lower, the variance σ² = ``noise_var`` of each
    residual, and optional standardized ``prior_rows`` G (M x D, same unit box); formulas in the
    module docstring. Raises :class:`BeliefError` for shapes or values it cannot use."""
    J, G, th, w = _checked(jacobian, noise_var, space, theta, width, prior_rows, pinned_pct)
    scale = np.where(th != 0.0, np.abs(th), w)               # s_j: relative to θ̂_j, or to the box at 0
    T = scale / w
    F_u = J.T @ J / float(noise_var) + G.T @ G
    F_x = F_u * T[:, None] * T[None, :]
    half_box = w / (2.0 * scale)
    values, vectors = np.linalg.eigh(0.5 * (F_x + F_x.T))
    largest = max(float(values.max()), 1e-300)
    values[values <= len(w) * np.finfo(float).eps * largest] = 0.0     # below eigh's rounding: no information
    mass = mass_exponents(space) * np.sign(th)
    p_hat = mass / np.linalg.norm(mass) if np.any(mass) else None
    names = space.names
    directions = tuple(_direction(float(values[k]), vectors[:, k], names, half_box, pinned_pct, p_hat)
                       for k in np.argsort(values)[::-1])
    symmetries = () if p_hat is None else (_symmetry(MASS_FORCE, p_hat, F_x, largest, half_box),)
    columns = np.linalg.norm(J, axis=0)
    inert = tuple(n for n, c in zip(names, columns, strict=True) if c <= INERT_RTOL * max(float(columns.max()), 0.0))
    tau = _RIDGE * max(float(np.mean(np.diag(F_u))), 1e-300)
    std = np.sqrt(np.clip(np.diag(np.linalg.inv(F_u + tau * np.eye(len(w)))), 0.0, None)) * w
    reference = np.where(space.nominal != 0.0, np.abs(space.nominal), w)
    return Identifiability(names=names, directions=directions, symmetries=symmetries, inert=inert,
                           marginal_pct=tuple(float(x) for x in 100.0 * std / reference), pinned_pct=float(pinned_pct))


def _checked(jacobian: np.ndarray, noise_var: float, space: ParameterSpace, theta: np.ndarray, width: np.ndarray,
             prior_rows: np.ndarray | None, pinned_pct: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """J (K x D), G (M x D, M = 0 without prior rows), θ̂ (D,), width (D,) as float arrays, validated."""
    d = space.dim
    J = np.asarray(jacobian, dtype=float)
    if J.ndim != 2 or J.shape[1] != d or not np.all(np.isfinite(J)):
        raise BeliefError(f"jacobian must be a finite K x {d} array (one column per parameter of the space), "
                          f"got shape {J.shape}.")
    G = np.zeros((0, d)) if prior_rows is None else np.asarray(prior_rows, dtype=float)
    if G.ndim != 2 or G.shape[1] != d or not np.all(np.isfinite(G)):
        raise BeliefError(f"prior_rows must be a finite M x {d} array in the unit box, got shape {G.shape}.")
    th, w = np.asarray(theta, dtype=float), np.asarray(width, dtype=float)
    if th.shape != (d,) or not np.all(np.isfinite(th)):
        raise BeliefError(f"theta must be {d} finite values (the fitted θ̂), got shape {th.shape}.")
    if w.shape != (d,) or not np.all(np.isfinite(w) & (w > 0)):
        raise BeliefError(f"width must be {d} box widths > 0 (upper − lower), got {w!r}.")
    if not (np.isfinite(noise_var) and noise_var > 0):
        raise BeliefError(f"noise_var must be a residual variance σ² > 0, got {noise_var!r}.")
    if not (np.isfinite(pinned_pct) and pinned_pct > 0):
        raise BeliefError(f"pinned_pct must be a width > 0 in %, got {pinned_pct!r}.")
    return J, G, th, w


def _direction(value: float, vector: np.ndarray, names: Sequence[str], half_box: np.ndarray, pinned_pct: float,
               p_hat: np.ndarray | None) -> Direction:
    """One eigenpair of F_x as a :class:`Direction` (sign: largest loading positive)."""
    v = vector * (1.0 if vector[np.argmax(np.abs(vector))] >= 0 else -1.0)
    width = 100.0 / np.sqrt(value) if value > 0 else np.inf
    box = 100.0 * _box(v, half_box)
    kind: DirectionKind = "pinned" if width < pinned_pct else "weak" if width < box else "free"
    label = "the mass–force scale" if p_hat is not None and abs(float(v @ p_hat)) >= _LABELLED else ""
    return Direction(information=value, width_pct=float(width), box_pct=box,
                     loadings=tuple(float(x) for x in v), text=direction_text(v, names), kind=kind, label=label)


def _symmetry(name: str, p_hat: np.ndarray, F_x: np.ndarray, largest: float, half_box: np.ndarray) -> Symmetry:
    """The symmetry along the unit vector ``p_hat`` and what F_x says of it."""
    info = max(float(p_hat @ F_x @ p_hat), 0.0)
    width = 100.0 / np.sqrt(info) if info > 0 else np.inf
    box = 100.0 * _box(p_hat, half_box)
    share = info / largest
    status: SymmetryStatus = "exact" if share <= SYMMETRY_RTOL else "near" if width >= box else "resolved"
    return Symmetry(name=name, loadings=tuple(float(x) for x in p_hat), information=info, share=share,
                    width_pct=float(width), box_pct=box, status=status)


def _box(v: np.ndarray, half_box: np.ndarray) -> float:
    """h(v) = 1 / √Σ (v_j / h_j)²: the half extent along the unit vector v of the ellipsoid inscribed
    in the box (half widths h_j, relative units)."""
    return float(1.0 / np.sqrt(np.sum((v / half_box) ** 2)))


def direction_text(v: np.ndarray, names: Sequence[str]) -> str:
    """"+0.55 density −0.49 maxTens": loadings with |v_j| >= 0.2 (the top 3 when none is), largest first."""
    order = np.argsort(-np.abs(v), kind="stable")
    chosen = [j for j in order if abs(v[j]) >= _LOADING] or list(order[:3])
    return " ".join(f"{v[j]:+.2f} {names[j]}".replace("-", "−") for j in chosen)


def _pct(width: float) -> str:
    """A width in % as text: "0.52 %", "35 %", "1.2e+05 %", "unbounded"."""
    if not np.isfinite(width):
        return "unbounded"
    if width < 10:
        return f"{width:.2g} %"
    return f"{width:.0f} %" if width < 1e4 else f"{width:.1e} %"


def _pm(width: float) -> str:
    """"±0.52 %", or "unbounded"."""
    return _pct(width) if not np.isfinite(width) else f"±{_pct(width)}"


def _out(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _records(data: Mapping[str, JSONValue], key: str) -> list[Mapping[str, JSONValue]]:
    value = data.get(key)
    if not isinstance(value, list) or not all(isinstance(x, dict) for x in value):
        raise BeliefError(f"identifiability dict: {key!r} must be a list of records, got {type(value).__name__}; "
                          "write it with Identifiability.as_dict().")
    return [x for x in value if isinstance(x, dict)]


def _float(data: Mapping[str, JSONValue], key: str) -> float:
    value = data.get(key, "missing")
    if value is None:
        return float("inf")
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise BeliefError(f"identifiability dict: {key!r} must be a number or None, got {value!r}.")
    return float(value)


def _floats(data: Mapping[str, JSONValue], key: str) -> tuple[float, ...]:
    value = data.get(key)
    if not isinstance(value, list):
        raise BeliefError(f"identifiability dict: {key!r} must be a list of numbers, got {value!r}.")
    return tuple(_float({key: x}, key) for x in value)


def _str(data: Mapping[str, JSONValue], key: str) -> str:
    value = data.get(key)
    if not isinstance(value, str):
        raise BeliefError(f"identifiability dict: {key!r} must be a string, got {value!r}.")
    return value


def _strs(data: Mapping[str, JSONValue], key: str) -> tuple[str, ...]:
    value = data.get(key)
    if not isinstance(value, list) or not all(isinstance(x, str) for x in value):
        raise BeliefError(f"identifiability dict: {key!r} must be a list of strings, got {value!r}.")
    return tuple(str(x) for x in value)


def _kind(value: str) -> DirectionKind:
    if value not in _KINDS:
        raise BeliefError(f"identifiability dict: a direction's kind must be one of {sorted(_KINDS)}, got {value!r}.")
    return _KINDS[value]


def _status(value: str) -> SymmetryStatus:
    if value not in _STATUSES:
        raise BeliefError(f"identifiability dict: a symmetry's status must be one of {sorted(_STATUSES)}, "
                          f"got {value!r}.")
    return _STATUSES[value]
