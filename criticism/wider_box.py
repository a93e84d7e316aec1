"""Parameters at a bound after the re-tuning, and whether a wider box frees them: the box is too narrow, or not.

A re-tuned value on the box's edge (belief.bounds) says the fit would move it further out if it could,
for one of two reasons the edge alone cannot tell apart: the truth lies outside the box (the box is too
narrow), or the parameter stands in for something the model lacks (an effect, an engine mismatch) and the
data push it as far as the box lets them. :func:`retuned_at_bounds` lists those parameters;
:func:`check_wider_box` tests them: each side a parameter is pinned at moves out by ``widen`` box widths
w = upper − lower, the other sides stay, and all D parameters are re-fitted from θ̃ on the fit segments F
in that wider box::

    upper' = upper + widen·w          lower' = max(lower − widen·w, m)          (m: the physical limit)

(a strict limit, such as a density's 0, is approached to ``limit_margin`` of the way: lower' >=
m + limit_margin·(lower − m); a bound that is the limit itself cannot be widened). The re-fit is
belief.least_squares.gauss_newton_fit on E_F (criticism.widened_objective): ``fit.steps`` damped
Gauss-Newton steps from finite-difference Jacobians, not another identification. θ̃ is already the
narrow box's optimum, so the steps go where the wider box lets the pinned parameters go, and the fit
ends with the Jacobian J at its end θ', which the attribution below needs.

With several parameters pinned, the re-fit's drop E_F(θ̃) − E_F(θ') is theirs together. What the room
of one parameter j buys is the profile difference: E_F with θ_j back on its old bound b_j and the others
re-fitted for it, minus E_F(θ')::

    ΔE_j = min(E_F(θ_b), E_F(θ̃)) − E_F(θ')        θ_b: θ_j = b_j, the others moved by one Gauss-Newton
                                                    step from θ' (J, r' at θ'; :func:`_profile`)

(θ̃ is itself a point with θ_j = b_j, hence the cap; ΔE_j = 0 unless j moved past b_j by more than
``beyond`` of the old width). Holding the others instead would credit j with what they would make up:
on the SUPERball, moving density alone breaks the mass-force scale that moving it with the
stiffnesses keeps. The test costs at most ``FitConfig.cost(D)`` evaluations, plus one per parameter
that moved past its bound (:meth:`WiderBoxConfig.cost`): with two steps, at most 53 + 15 for the
T6's 15 parameters.

The verdict per parameter (:data:`VERDICTS`):

- "box too narrow": it moved past its old bound by more than ``beyond`` of the old width AND that
  lowered the fit error significantly, ΔE_j > 2·nats·σ² when the run's likelihood σ² per residual
  is known (a gain of ``nats`` in the log-likelihood −E/(2σ²)), else ΔE_j > ``relative``·E_F(θ̃);
- "compensation" (for a missing effect or an engine mismatch) otherwise: given room it stays, or moves
  without the data gaining, so the edge was not holding back an estimate; a bound at the physical
  limit is always this.

Both speak of this model: a parameter standing in for a missing effect that gains significantly
from the room is called "too narrow" as well, and the value it moved to says how far out the data
want it.
"""
from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from belief.bounds import AT_BOUND_TOLERANCE, AtBound, at_bounds, inadequacy_text
from belief.least_squares import FitConfig, LocalStep, gauss_newton_fit
from criticism.errors import CriticismError
from criticism.widened_objective import WidenedObjective
from physics.objective import Objective
from physics.parameters import Parameter, ParameterSpace

if TYPE_CHECKING:
    from belief.belief import Belief

__all__ = ["TOO_NARROW", "COMPENSATION", "VERDICTS", "WiderBoxConfig", "BoundOutcome", "WiderBoxCheck",
           "widened_space", "check_wider_box", "run_noise_var", "retuned_at_bounds",
           "tested_text"]

TOO_NARROW = "box too narrow"
COMPENSATION = "compensation"
#: the verdicts of a pinned parameter (module docstring)
VERDICTS = (TOO_NARROW, COMPENSATION)


@dataclass(frozen=True)
class WiderBoxConfig:
    """widen: each pinned side moves out by this many widths of the parameter's box; limit_margin: the
    fraction of the way to a strict physical limit a lower bound may not cross; fit: the re-fit
    (Gauss-Newton steps, belief.least_squares.FitConfig); nats: with σ² known, the error must drop by
    more than 2·nats·σ²; relative: without σ², by more than this fraction of E; beyond: a move past
    the old bound counts when larger than this fraction of the old box width (module docstring)."""

    widen: float = 1.0
    limit_margin: float = 0.1
    fit: FitConfig = FitConfig(steps=2)
    nats: float = 1.0
    relative: float = 0.01
    beyond: float = 0.01

    def __post_init__(self) -> None:
        if not isinstance(self.fit, FitConfig):
            raise CriticismError(f"WiderBoxConfig.fit must be a belief.least_squares.FitConfig, got "
                                 f"{type(self.fit).__name__}.")
        numbers = (self.widen, self.limit_margin, self.nats, self.relative, self.beyond)
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in numbers):
            raise CriticismError(f"WiderBoxConfig needs finite numbers, got {numbers}.")
        if not (self.widen > 0 and 0 < self.limit_margin < 1 and self.nats > 0 and 0 < self.relative < 1
                and 0 <= self.beyond < 1):
            raise CriticismError(f"WiderBoxConfig needs widen > 0, 0 < limit_margin < 1, nats > 0, 0 < relative < 1 "
                                 f"and 0 <= beyond < 1, got {self.widen}, {self.limit_margin}, {self.nats}, "
                                 f"{self.relative}, {self.beyond}.")

    def cost(self, dim: int, pinned: int | None = None) -> int:
        """The most evaluations of E one test in ``dim`` parameters spends with ``pinned`` of them at a bound
        (None: all of them, the most it can be; module docstring)."""
        return self.fit.cost(dim) + (dim if pinned is None else pinned)


def _widened(p: Parameter, side: str, config: WiderBoxConfig) -> tuple[float, float]:
    """``p``'s box with its ``side`` widened (module docstring)."""
    width = p.upper - p.lower
    if side == "upper":
        return p.lower, p.upper + config.widen * width
    lower = p.lower - config.widen * width
    if np.isfinite(p.minimum):
        limit = p.minimum + config.limit_margin * (p.lower - p.minimum) if p.strict else p.minimum
        lower = max(lower, min(limit, p.lower))
    return lower, p.upper


def widened_space(space: ParameterSpace, entries: Sequence[AtBound], config: WiderBoxConfig) -> ParameterSpace:
    """``space`` with the side of each entry's parameter widened (module docstring), the rest unchanged."""
    bounds = {e.name: _widened(space[e.name], e.side, config) for e in entries}
    changed = {name: box for name, box in bounds.items() if box != (space[name].lower, space[name].upper)}
    return space.with_overrides(bounds=changed) if changed else space


@dataclass(frozen=True)
class BoundOutcome:
    """What the wider box did to one pinned parameter: its ``name``, ``unit``, ``side``, old ``bound`` and
    the old box's ``other`` bound, the ``widened`` bound (== bound at a physical limit: not testable), its
    value ``start`` at θ̃ and ``value`` after the re-fit, whether that ``moved`` it past the old bound (by more
    than WiderBoxConfig.beyond of the old width), the fit error E_F at θ̃ (``error_before``), after
    the whole re-fit (``error_after``) and with this parameter put back on its old bound, the others
    re-fitted for it (``error_back``, the module docstring's min(E_F(θ_b), E_F(θ̃)); == error_after when it
    did not move past the bound), the drop ``needed`` to count, the run's σ² (None: unknown, the relative
    rule) and the ``verdict``."""

    name: str
    unit: str
    side: str
    bound: float
    other: float
    widened: float
    start: float
    value: float
    moved: bool
    error_before: float
    error_after: float
    error_back: float
    needed: float
    noise_var: float | None
    verdict: str

    def __post_init__(self) -> None:
        if self.side not in ("lower", "upper") or self.verdict not in VERDICTS:
            raise CriticismError(f"BoundOutcome of {self.name!r}: side must be 'lower' or 'upper' and verdict one of "
                                 f"{VERDICTS}, got {self.side!r}, {self.verdict!r}.")

    @property
    def testable(self) -> bool:
        """Whether the box could be widened on that side (not at the physical limit)."""
        return self.widened != self.bound

    @property
    def beyond(self) -> float:
        """How far the re-fit moved it past the old bound, outward positive (its units)."""
        return self.value - self.bound if self.side == "upper" else self.bound - self.value

    @property
    def gain(self) -> float:
        """ΔE_j: how much lower E_F is for the parameter's move past its bound (module docstring)."""
        return self.error_back - self.error_after

    @property
    def change(self) -> float:
        """−ΔE_j / E_F(θ̃) (−0.04: its room lowered the error 4 %)."""
        return -self.gain / self.error_before if self.error_before > 0 else 0.0

    def _nats(self, gain: float) -> str:
        return "" if self.noise_var is None else f" ({gain / (2 * self.noise_var):.3g} nats)"

    def advice(self, *, flag: bool = False, narrow: Sequence[str] = ()) -> str:
        """What was tested and the verdict in words; ``flag``: the parameter is one ``--bounds`` sets;
        ``narrow``: the parameters of the same test whose box is too narrow, which one that moved back
        inside may have stood in for."""
        unit = "" if self.unit in ("", "1") else f" {self.unit}"
        if not self.testable:
            return (f"{self.bound:.4g}{unit} is its physical limit, so no wider box can be tried -> compensation "
                    "for a missing effect or an engine mismatch: the value is not an estimate")
        lo, hi = sorted((self.other, self.widened))
        tried = f"the box widened to {self.widened:.4g}{unit}"
        moved = (f"moved it to {self.value:.4g}{unit}, which lowers the error by {-100 * self.change:.1f} %"
                 f"{self._nats(self.gain)}")
        if self.verdict == TOO_NARROW:
            how = f"--bounds {self.name}={lo:.4g}:{hi:.4g}" if flag else f"to [{lo:.4g}, {hi:.4g}]{unit}"
            reached = abs(self.value - self.widened) <= AT_BOUND_TOLERANCE * abs(self.widened - self.other)
            further = "; it reached the widened bound too: widen further" if reached else ""
            return f"re-fitting with {tried} {moved} -> the box is too narrow: widen it ({how}){further}"
        lacks = "a missing effect or an engine mismatch"
        inside = not self.moved and self.beyond < -AT_BOUND_TOLERANCE * abs(self.bound - self.other)
        if not self.moved:
            moved = f"{'moved it back inside, to' if inside else 'left it at'} {self.value:.4g}{unit}"
        others = [n for n in narrow if n != self.name]
        if inside and others:
            return (f"re-fitting with {tried} {moved} -> compensation: it stood in for {', '.join(others)} (box too "
                    f"narrow), {lacks}; the value is not an estimate")
        return f"re-fitting with {tried} {moved} -> compensation for {lacks}: the value is not an estimate"

    def as_dict(self) -> dict[str, Any]:
        """A JSON-able record (diagnosis.json), with ``beyond``, ``gain`` and ``change``."""
        return {**asdict(self), "beyond": self.beyond, "gain": self.gain, "change": self.change}


@dataclass(frozen=True)
class WiderBoxCheck:
    """The test of :func:`check_wider_box`: one outcome per pinned parameter, θ' the re-fit's end (D,),
    the evaluations of E it spent, ``widen`` (box widths) and the rule's words."""

    outcomes: tuple[BoundOutcome, ...]
    theta: tuple[float, ...]
    evaluations: int
    widen: float
    rule: str

    def notes(self, settable: Collection[str] = ()) -> dict[str, str]:
        """Parameter name -> :meth:`BoundOutcome.advice` (``settable``: the names ``--bounds`` sets)."""
        narrow = [o.name for o in self.outcomes if o.verdict == TOO_NARROW]
        return {o.name: o.advice(flag=o.name in settable, narrow=narrow) for o in self.outcomes}

    def closing(self) -> str:
        """The block's last line: how the parameters were tested."""
        first = self.outcomes[0]
        whole = 100 * (first.error_after / first.error_before - 1.0) if first.error_before > 0 else 0.0
        nats = ("" if first.noise_var is None
                else f", {(first.error_before - first.error_after) / (2 * first.noise_var):.3g} nats")
        return (f"Tested by re-fitting all {len(self.theta)} parameters on the fit data in the box widened by "
                f"{self.widen:g} x its width on each pinned side ({self.evaluations} evaluations of E; the whole "
                f"re-fit changed the error by {whole:+.1f} %{nats}): \"too "
                f"narrow\" needs a move past the old bound and an error drop of more than {self.rule}; "
                "\"compensation\": the parameter stands in for something the model lacks.")

    def as_dict(self) -> dict[str, Any]:
        """A JSON-able record (diagnosis.json)."""
        return {"outcomes": [o.as_dict() for o in self.outcomes], "theta": list(self.theta),
                "evaluations": self.evaluations, "widen": self.widen, "rule": self.rule}


def run_noise_var(belief: Belief | None, objective: Objective) -> float | None:
    """The run's likelihood σ² per residual: the identification's (Belief attrs "noise_var"), else the
    objective's known one, else None."""
    value = None if belief is None else belief.attrs.get("noise_var")
    value = objective.noise_var if value is None else value
    return float(value) if value is not None and np.isfinite(value) and value > 0 else None


def _flat(residuals: Sequence[np.ndarray]) -> np.ndarray:
    """Residuals as one vector, NaN (not compared) as 0, as belief.least_squares stacks them."""
    return np.nan_to_num(np.concatenate([np.ravel(r) for r in residuals]), nan=0.0)


def _profile(step: LocalStep, residuals: Sequence[np.ndarray], space: ParameterSpace, j: int, bound: float,
             ridge: float) -> np.ndarray:
    """θ (D,) with θ_j on ``bound`` and the others where one Gauss-Newton step from the fit's end θ' puts
    them for it: min ||r' + J_j δ + J_o Δ||² + λ||Δ||² over the others' Δ, in ``space``'s unit box
    (J (K x D) and r' at θ', ``step``; λ = ``ridge`` x mean diag JᵀJ keeps a direction the data do not see,
    such as the mass-force scale, from running to the box's corner)."""
    from scipy.optimize import lsq_linear

    lower, width = space.lower, space.upper - space.lower
    u = (step.theta - lower) / width
    delta = (bound - lower[j]) / width[j] - u[j]
    others = [k for k in range(space.dim) if k != j]
    J = np.nan_to_num(step.jacobian)
    lam = ridge * max(float(np.mean(np.sum(J * J, axis=0))), 1e-300)
    A = np.vstack([J[:, others], np.sqrt(lam) * np.eye(len(others))])
    b = np.concatenate([-(_flat(residuals) + J[:, j] * delta), np.zeros(len(others))])
    move = lsq_linear(A, b, bounds=(-u[others], 1.0 - u[others] + 1e-15)).x
    point = u.copy()
    point[others] += move
    point[j] += delta
    return lower + width * np.clip(point, 0.0, 1.0)


def _put_back(fitted: WidenedObjective, step: LocalStep, residuals: Sequence[np.ndarray],
              entries: Sequence[AtBound], past: Sequence[AtBound], error_before: float) -> tuple[dict[str, float], int]:
    """E_F with the parameter of each entry in ``past`` (those the re-fit moved past their bound) put back
    on its old bound and the others re-fitted for it by one Gauss-Newton step (:func:`_profile`, evaluated
    in one batch), capped by E_F(θ̃), itself a point on that bound; E_F(θ') for the other ``entries``.
    Returns name -> E_F and the evaluations spent."""
    space = fitted.space
    back = {e.name: step.error for e in entries}
    if past:
        rows = np.stack([_profile(step, residuals, space, space.index(e.name), e.bound, 1e-6) for e in past])
        errors = fitted.evaluate_batch(rows).errors
        back.update({e.name: min(float(v), error_before) if np.isfinite(v) else error_before
                     for e, v in zip(past, errors, strict=True)})
    return back, len(past)


def check_wider_box(objective: Objective, theta: np.ndarray, entries: Sequence[AtBound],
                    fit: np.ndarray | Sequence[bool], *, noise_var: float | None = None,
                    config: WiderBoxConfig = WiderBoxConfig()) -> WiderBoxCheck | None:
    """Re-fit all parameters of ``objective`` from θ (D,) on the segments ``fit`` (S,) in the box widened
    at ``entries`` (the parameters at a bound of θ, belief.bounds), read what each one's room buys, and
    classify each (module docstring); ``noise_var``: the run's σ² per residual (None: the relative rule).
    None when ``entries`` is empty."""
    if not entries:
        return None
    space = objective.space
    fitted = WidenedObjective(objective, widened_space(space, entries, config), fit)
    start = np.asarray(theta, float)
    step, residuals = gauss_newton_fit(fitted, start, config.fit)
    before, after = step.start_error, step.error
    width = space.upper - space.lower
    outward = {e.name: (step.theta[space.index(e.name)] - e.bound) * (1 if e.side == "upper" else -1) for e in entries}
    past = [e for e in entries if outward[e.name] > config.beyond * width[space.index(e.name)]]
    back, spent = _put_back(fitted, step, residuals, entries, past, before)
    needed = 2.0 * config.nats * noise_var if noise_var is not None else config.relative * before
    rule = (f"{config.nats:g} nat (2σ² = {needed:.3g})" if noise_var is not None
            else f"{100 * config.relative:g} % of E (σ² unknown)")
    outcomes = []
    for e in entries:
        j = space.index(e.name)
        widened = float(fitted.space.upper[j] if e.side == "upper" else fitted.space.lower[j])
        moved = e in past
        narrow = widened != e.bound and moved and back[e.name] - after > needed
        outcomes.append(BoundOutcome(e.name, e.unit, e.side, e.bound,
                                     float(space.lower[j] if e.side == "upper" else space.upper[j]), widened,
                                     float(start[j]), float(step.theta[j]), moved, before, after, back[e.name],
                                     needed, noise_var, TOO_NARROW if narrow else COMPENSATION))
    return WiderBoxCheck(tuple(outcomes), tuple(float(v) for v in step.theta), step.evaluations + spent,
                         config.widen, rule)


def retuned_at_bounds(space: ParameterSpace, start: np.ndarray, retuned: np.ndarray, belief: Belief | None, *,
                      tolerance: float = AT_BOUND_TOLERANCE) -> tuple[AtBound, ...]:
    """The parameters at a bound of the re-tuned θ̃ (D,) that the re-tuning moved there from θ̂
    (``start``, D,), or that the identification's ``belief`` already lists at that bound (the "at
    bound" verdict rule). A value already on the edge at θ̂ that the data do not narrow is left out:
    BO's best point can sit there by chance (belief.verdicts)."""
    known = {(a.name, a.side) for a in (belief.at_bounds if belief is not None else ())}
    moved = {a.name for a in at_bounds(space, retuned, tolerance=tolerance, start=start)}
    found = at_bounds(space, retuned, tolerance=tolerance, source="re-tuning")
    return tuple(a for a in found if a.name in moved or (a.name, a.side) in known)


def tested_text(entries: Sequence[AtBound], check: WiderBoxCheck | None, *, after: str = "the re-tuning",
                tolerance: float = AT_BOUND_TOLERANCE, settable: Collection[str] = ()) -> str:
    """The "Model inadequacy" block (belief.bounds.inadequacy_text) with, under each parameter, what the
    wider box did to it and the verdict, and how it was tested; ``settable``: the parameter names
    ``--bounds`` sets (their advice names the option). Without a check the block says it was not tested."""
    if check is None:
        n = len(entries)
        closing = ("Not tested in a wider box: the model may lack an effect "
                   + ("this parameter stands" if n == 1 else "these parameters stand")
                   + " in for, or the box is too narrow: "
                   + ("this value is not an estimate." if n == 1 else "these values are not estimates."))
        return inadequacy_text(entries, after=after, tolerance=tolerance, closing=closing)
    return inadequacy_text(entries, after=after, tolerance=tolerance, notes=check.notes(settable),
                           closing=check.closing())
