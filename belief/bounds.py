"""Parameters pinned at a bound of the prior box after fitting: evidence of model inadequacy.

A fit confined to the box [lower, upper] that ends on the box's edge in parameter j says that the
data would move θ_j further out if they could. The value there is the bound, not an estimate: the
model may lack an effect (another engine's contact law, a sensor bias) that θ_j stands in for, or
the box is too narrow. This module cannot tell which; ``tensegrid diagnose`` tests it by re-fitting
in a wider box (criticism.wider_box). In the unit box u = (θ - lower) / (upper - lower)
(physics.parameters)::

    at the lower bound:  u_j <= tolerance          at the upper bound:  u_j >= 1 - tolerance

with ``tolerance`` a fraction of the box width (:data:`AT_BOUND_TOLERANCE`, 1 %). :func:`at_bounds`
is this test alone; who calls it decides which fitted θ counts and which parameters the data see:
:mod:`belief.verdicts`' "at bound" rule in identify (parameters P narrows, at the local fit or the
best evaluation), :mod:`criticism.diagnose` (parameters the re-tuning moved to a bound, or identify had
pinned there). Every entry is an :class:`AtBound`; :func:`inadequacy_text` is the block the
summaries print.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from belief.errors import BeliefError

if TYPE_CHECKING:
    from physics.parameters import ParameterSpace

__all__ = ["AT_BOUND_TOLERANCE", "SIDES", "AtBound", "at_bounds", "entries_from_records", "inadequacy_text"]

#: default distance from a bound, as a fraction of the box width, within which a fitted value is "at" it
AT_BOUND_TOLERANCE = 0.01
#: the two bounds of a parameter's box
SIDES = ("lower", "upper")


@dataclass(frozen=True)
class AtBound:
    """One parameter at a bound: ``name``, ``unit``, ``side`` ("lower" or "upper"), ``bound`` (the
    bound's value), ``value`` (the fitted θ_j), ``nominal`` (the space's nominal θ_j) and ``source``
    (which fit: "local fit", "best evaluation", "re-tuning")."""

    name: str
    unit: str
    side: str
    bound: float
    value: float
    nominal: float
    source: str = "fit"

    def __post_init__(self) -> None:
        if self.side not in SIDES:
            raise BeliefError(f"AtBound.side must be one of {SIDES}, got {self.side!r}.")
        for key in ("bound", "value", "nominal"):
            if not np.isfinite(getattr(self, key)):
                raise BeliefError(f"AtBound.{key} of {self.name!r} must be finite, got {getattr(self, key)!r}.")

    @property
    def relative(self) -> float | None:
        """bound / nominal - 1 (the bound's offset from nominal, e.g. +0.1 for a ±10 % box); None at nominal 0."""
        return None if self.nominal == 0 else self.bound / self.nominal - 1.0

    def describe(self) -> str:
        """``"stiffnessActive at upper bound 880 N/m (+10 % of nominal)"``."""
        unit = "" if self.unit in ("", "1") else f" {self.unit}"
        rel = "" if self.relative is None else f" ({100 * self.relative:+.0f} % of nominal)"
        return f"{self.name} at {self.side} bound {self.bound:.4g}{unit}{rel}"

    def reason(self) -> str:
        """The verdict reason of a pinned parameter (the "at bound" rule of belief.verdicts)."""
        return (f"pinned at the {self.side} bound {self.bound:.4g} by the {self.source}: the data push it out of "
                "the box, so the value is the bound, not an estimate (the model may lack an effect it stands in "
                "for, or the box is too narrow; tensegrid diagnose tests which)")

    def as_dict(self) -> dict[str, Any]:
        """A JSON-able record (the Belief's attrs["at_bounds"], diagnosis.json)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, record: Mapping[str, Any]) -> AtBound:
        """Inverse of :meth:`as_dict`; a record that is not one raises :class:`BeliefError`."""
        try:
            return cls(str(record["name"]), str(record["unit"]), str(record["side"]), float(record["bound"]),
                       float(record["value"]), float(record["nominal"]), str(record.get("source", "fit")))
        except (KeyError, TypeError, ValueError) as exc:
            raise BeliefError(f"not an at-bound record ({exc}): {record!r}; write one with "
                              "AtBound.as_dict().") from None


def entries_from_records(records: Any, names: Sequence[str]) -> tuple[AtBound, ...]:
    """AtBound entries of a list of :meth:`AtBound.as_dict` records (None: none) over parameters ``names``."""
    if records is None:
        return ()
    if not isinstance(records, list):
        raise BeliefError("at-bound records must be a list of AtBound.as_dict() records, got "
                          f"{type(records).__name__}.")
    entries = tuple(AtBound.from_dict(r) for r in records)
    unknown = sorted({e.name for e in entries} - set(names))
    if unknown:
        raise BeliefError(f"at-bound records name {unknown}, which are not parameters {list(names)}.")
    return entries


def _check_tolerance(tolerance: float) -> float:
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or not 0 <= tolerance < 0.5:
        raise BeliefError(f"tolerance must be a fraction of the box width in [0, 0.5), e.g. {AT_BOUND_TOLERANCE}, "
                          f"got {tolerance!r}.")
    return float(tolerance)


def _sides(u: np.ndarray, tolerance: float) -> list[str | None]:
    """Per coordinate of the unit-box point ``u`` (D,): "lower", "upper" or None (module docstring)."""
    eps = 1e-12
    return ["lower" if v <= tolerance + eps else "upper" if v >= 1.0 - tolerance - eps else None for v in u]


def at_bounds(space: ParameterSpace, theta: np.ndarray | Sequence[float], *, tolerance: float = AT_BOUND_TOLERANCE,
              source: str = "fit",
              start: np.ndarray | Sequence[float] | None = None) -> tuple[AtBound, ...]:
    """The parameters of θ (shape ``D``, in ``space``'s order) within ``tolerance`` x width of a bound.

    ``space``: a physics ParameterSpace (names, units, nominal, lower, upper); ``source``:
    names the fit in the entries; ``start``: θ before the fit (``D``): when given, only the
    parameters the fit *moved* to a bound are listed (those not already at that bound at the start).
    Values outside the box count as at the bound they passed. Entries in the space's order.
    """
    tol = _check_tolerance(tolerance)
    th = np.asarray(theta, dtype=float)
    if th.shape != (space.dim,) or not np.all(np.isfinite(th)):
        raise BeliefError(f"theta must be finite with shape ({space.dim},) in the order {list(space.names)}, "
                          f"got shape {th.shape}.")
    lower, upper, nominal = space.lower, space.upper, space.nominal
    sides = _sides((th - lower) / (upper - lower), tol)
    before: list[str | None] = [None] * space.dim
    if start is not None:
        st = np.asarray(start, dtype=float)
        if st.shape != th.shape or not np.all(np.isfinite(st)):
            raise BeliefError(f"start must be finite with shape ({space.dim},) like theta, got shape {st.shape}.")
        before = _sides((st - lower) / (upper - lower), tol)
    return tuple(AtBound(space.names[j], space.units[j], side, float(lower[j] if side == "lower" else upper[j]),
                         float(th[j]), float(nominal[j]), source)
                 for j, side in enumerate(sides) if side is not None and side != before[j])


def inadequacy_text(entries: Sequence[AtBound], *, after: str = "fitting",
                    tolerance: float = AT_BOUND_TOLERANCE, notes: Mapping[str, str] | None = None,
                    closing: str | None = None) -> str:
    """The "Model inadequacy" block of a summary, one line per parameter; "" when ``entries`` is empty.

    ``after``: what produced the values ("fitting", "the re-tuning"); ``tolerance``: the one of the test;
    ``notes``: parameter name -> a line printed under its entry (what a test of it found,
    criticism.wider_box); ``closing``: the block's last line (default: what is known without a test,
    that the value is not an estimate and why it may sit there).
    """
    if not entries:
        return ""
    n = len(entries)
    head = (f"Model inadequacy: {n} parameter{' sits' if n == 1 else 's sit'} at a bound of the prior box after "
            f"{after} (within {100 * tolerance:g} % of the box width):")
    lines = [head]
    for e in entries:
        lines.append(f"  {e.describe()}; fitted {e.value:.5g} ({e.source})")
        if notes and e.name in notes:
            lines.append(f"    {notes[e.name]}")
    if closing is None:
        closing = ("The model may lack an effect " + ("this parameter stands" if n == 1 else "these parameters stand")
                   + " in for, or the box is too narrow (`tensegrid diagnose` tests which): "
                   + ("this value is not an estimate." if n == 1 else "these values are not estimates."))
    lines.append(closing)
    return "\n".join(lines)
