"""Least-squares fits of an actuator law (physics.actuator_laws) to encoder readings.

The data are :class:`ActuatorRecord` s (one per trajectory, on its regular clock) and the cables
fitted in each (:class:`Selection`). For a law form the fit minimises

    RSS(d, r, τ, s, o) = Σ_k Σ_j Σ_i [R_kij - P_kij(d, r, τ, s) - o_j]²

over the compared samples (reading and command both recorded), P the law's prediction without
offsets, o_j [m] one offset per cable shared by all trajectories. Offsets are profiled out in closed
form, o_j = mean residual of cable j (exact without a tension limit, where R(c + o) = R(c) + o;
with one, three such passes). The delay d is profiled on a grid (whole samples, then a fine grid
around the best whole one), and at each d the other parts (log r, log τ, log s) by
``scipy.optimize.least_squares``: from several starts at the first and at the best whole sample,
elsewhere warm-started from the neighbouring grid point (a rate limit and a lag trade off, so one
start can stall in the wrong valley).

Intervals account for residuals that are correlated in time (a misfit shared by neighbouring
samples): the effective sample size is n_eff = Σ_pairs n_p (1 - ρ_p) / (1 + ρ_p), ρ_p the lag-1
autocorrelation of the residuals of one cable of one trajectory (AR(1)), and

- the delay's is the profile interval {d : RSS(d) <= RSS_min (1 + χ²₁(level) / n_eff)} (a likelihood
  ratio on the residual scale; it handles the bound d >= 0 and the kinks at whole samples, which a
  Gauss-Newton sd does not);
- the other parts' are Gauss-Newton intervals in log space, cov = RSS / (n_eff - p) (JᵀJ)⁺ at the
  best d, J the Jacobian of the residuals in log r, log τ, log s;
- an offset's sd is σ_j / sqrt(n_eff,j), σ_j² the cable's mean squared residual.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2

from physics.actuator_laws import ActuatorLaw, LawForm, chain_readings
from physics.errors import ParameterError

__all__ = ["ActuatorRecord", "Columns", "Selection", "FitOptions", "FormFit", "fit_form", "evaluate", "offset_sd"]

#: Bounds of the free parts in log space: rate [m/s], time constant [s], tension slack [m].
_BOUNDS = {"rate": (1e-3, 1e3), "time_constant": (1e-4, 5.0), "tension_slack": (1e-4, 2.0)}


@dataclass(frozen=True, eq=False)
class Columns:
    """Some cables of a record, ready for the fitting loop: ``index`` the cables, ``commands``,
    ``readings`` (0 where not compared), ``mask`` (True where compared), ``floor_base`` the cable
    lengths (-inf where unknown) (T x m each), ``count`` compared samples per cable (m,)."""

    index: np.ndarray
    commands: np.ndarray
    readings: np.ndarray
    mask: np.ndarray
    floor_base: np.ndarray
    count: np.ndarray


@dataclass(frozen=True, eq=False)
class ActuatorRecord:
    """One trajectory's actuator data on its regular clock: ``commands`` (T x 24) [m], finite (a
    missing command holds the last one sent), ``readings`` (T x 24) [m] (NaN: missing),
    ``compared`` (T x 24) bool (reading and command both recorded), ``lengths`` (T x 24) [m]
    observed cable lengths or None, ``interval`` Δ [s], ``name``."""

    commands: np.ndarray
    readings: np.ndarray
    compared: np.ndarray
    lengths: np.ndarray | None
    interval: float
    name: str
    _columns: dict[tuple[int, ...], Columns] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        shape = np.shape(self.commands)
        arrays = (("readings", self.readings), ("compared", self.compared), ("lengths", self.lengths))
        for what, array in arrays:
            if array is not None and np.shape(array) != shape:
                raise ParameterError(f"ActuatorRecord.{what} has shape {np.shape(array)}, the commands {shape}; "
                                     "give every array as (time, cable).")
        if len(shape) != 2 or shape[1] != 24 or not np.all(np.isfinite(self.commands)):
            raise ParameterError(f"ActuatorRecord.commands must be finite (T x 24) [m], got shape {shape}; hold the "
                                 "last command over a missing one (physics.actuator_readings.actuator_record does).")
        if not (math.isfinite(self.interval) and self.interval > 0):
            raise ParameterError(f"ActuatorRecord.interval must be the sample interval > 0 s, got {self.interval!r}.")

    def columns(self, cables: tuple[int, ...]) -> Columns:
        """The :class:`Columns` of ``cables`` (made once per set of cables)."""
        if cables not in self._columns:
            cols = list(cables)
            mask = np.ascontiguousarray(self.compared[:, cols])
            lengths = self.lengths[:, cols] if self.lengths is not None else np.full(mask.shape, np.nan)
            self._columns[cables] = Columns(
                np.array(cols, dtype=np.int64), np.ascontiguousarray(self.commands[:, cols]),
                np.ascontiguousarray(np.where(mask, self.readings[:, cols], 0.0)), mask,
                np.ascontiguousarray(np.where(np.isfinite(lengths), lengths, -np.inf)), mask.sum(axis=0))
        return self._columns[cables]


@dataclass(frozen=True)
class Selection:
    """The cables fitted in each record: ``cables[k]`` the cable indices of record k."""

    cables: tuple[tuple[int, ...], ...]

    def pairs(self) -> list[tuple[int, int]]:
        """(record, cable) pairs, in order."""
        return [(k, j) for k, cables in enumerate(self.cables) for j in cables]

    @classmethod
    def of(cls, pairs: list[tuple[int, int]], n_records: int) -> Selection:
        return cls(tuple(tuple(j for k, j in pairs if k == r) for r in range(n_records)))


@dataclass(frozen=True, kw_only=True)
class FitOptions:
    """How a form is fitted: the delay grid's end ``max_delay`` [s] and fine step ``fine_step``
    [samples]; ``offsets``: profile one offset per cable (else none)."""

    max_delay: float
    fine_step: float
    offsets: bool


@dataclass(frozen=True, eq=False)
class FormFit:
    """A form fitted: ``law`` at its best values (offsets (24,), 0 where no cable was fitted),
    ``rss`` [m²] over ``n`` compared samples, ``n_eff`` their effective number, the delay
    ``profile`` (delays [s], RSS [m²]), ``log_sd`` the Gauss-Newton sd of each free part's log
    (name -> sd), ``offset_sd`` (24,) [m] and ``residuals`` (one (T x m_k) array per record, NaN
    where not compared, columns the selection's cables), ``log_parts`` the fitted parts' logs (p,)."""

    law: ActuatorLaw
    rss: float
    n: int
    n_eff: float
    profile: tuple[np.ndarray, np.ndarray]
    log_sd: dict[str, float]
    offset_sd: np.ndarray
    residuals: tuple[np.ndarray, ...]
    log_parts: np.ndarray

    def delay_interval(self, level: float) -> tuple[float, float]:
        """The profile interval of the delay [s] at ``level`` (module docstring); (0, 0) without a delay."""
        delays, rss = self.profile
        if not self.law.form.delay:
            return 0.0, 0.0
        threshold = self.rss * (1.0 + chi2.ppf(level, 1) / max(self.n_eff, 1.0))
        best = int(np.argmin(rss))
        return _crossing(delays, rss, threshold, best, -1), _crossing(delays, rss, threshold, best, 1)

    def part_interval(self, name: str, value: float, level: float) -> tuple[float, float]:
        """The Gauss-Newton interval of a part (rate, time_constant, tension_slack) in log space."""
        sd = self.log_sd.get(name, math.inf)
        z = math.sqrt(chi2.ppf(level, 1))
        if not math.isfinite(sd):
            return 0.0, math.inf
        return value * math.exp(-z * sd), value * math.exp(z * sd)


def _crossing(x: np.ndarray, y: np.ndarray, threshold: float, start: int, direction: int) -> float:
    """Where y first rises above ``threshold`` walking from ``start`` in ``direction`` (linear between
    grid points); the grid's end when it never does."""
    i = start
    while 0 <= i + direction < x.size and y[i + direction] <= threshold:
        i += direction
    if not 0 <= i + direction < x.size:
        return float(x[i])
    a, b = y[i], y[i + direction]
    w = (threshold - a) / (b - a) if b != a else 0.0
    return float(x[i] + w * (x[i + direction] - x[i]))


def _free(form: LawForm) -> tuple[str, ...]:
    """The parts fitted by least squares (all but the delay and the offsets)."""
    return tuple(n for n, on in (("rate", form.rate_limit), ("time_constant", form.lag),
                                 ("tension_slack", form.tension_limit)) if on)


def _law(form: LawForm, delay: float, x: np.ndarray, offsets: tuple[float, ...] = ()) -> ActuatorLaw:
    values = dict(zip(_free(form), np.exp(x), strict=True))
    return ActuatorLaw(form=form, delay=delay if form.delay else 0.0, offsets=offsets,
                       **{k: float(v) for k, v in values.items()})


def evaluate(records: list[ActuatorRecord], selection: Selection, law: ActuatorLaw, fit_offsets: bool
             ) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """Residuals R - P - o (one (T x m_k) array per record, NaN where not compared, columns the
    selection's cables) and the offsets (24,) [m] profiled out (zeros when ``fit_offsets`` is False
    or for cables not selected)."""
    residuals, offsets = _residuals(records, selection, law, fit_offsets)
    return tuple(np.where(c.mask, e, np.nan) for e, c in residuals), offsets


def _residuals(records: list[ActuatorRecord], selection: Selection, law: ActuatorLaw, fit_offsets: bool
               ) -> tuple[list[tuple[np.ndarray, Columns]], np.ndarray]:
    """(residual (T x m_k), 0 where not compared; its Columns) per record, and the offsets (24,) [m]."""
    columns = [rec.columns(cables) for rec, cables in zip(records, selection.cables, strict=True)]
    count = np.zeros(24)
    for c in columns:
        np.add.at(count, c.index, c.count)
    offsets, step = np.zeros(24), np.zeros(24)
    passes = 3 if (law.form.tension_limit and fit_offsets) else 1
    for _ in range(passes):
        total, errors = np.zeros(24), []
        for rec, c in zip(records, columns, strict=True):
            targets = c.commands + offsets[c.index] if offsets.any() else c.commands
            floors = c.floor_base - law.tension_slack if law.form.tension_limit else None
            e = c.readings - chain_readings(targets, floors, rec.interval, law.delay, law.rate, law.time_constant)
            e[~c.mask] = 0.0
            errors.append(e)
            np.add.at(total, c.index, e.sum(axis=0))
        step = np.divide(total, count, out=np.zeros(24), where=count > 0) if fit_offsets else np.zeros(24)
        offsets = offsets + step
    out = []
    for e, c in zip(errors, columns, strict=True):
        e -= step[c.index]
        e[~c.mask] = 0.0
        out.append((e, c))
    return out, offsets


def _vector(records: list[ActuatorRecord], selection: Selection, law: ActuatorLaw, fit_offsets: bool) -> np.ndarray:
    """The compared residuals of all records as one vector (least squares' residual function)."""
    parts = [e[c.mask] for e, c in _residuals(records, selection, law, fit_offsets)[0]]
    return np.concatenate(parts) if parts else np.zeros(0)


def _fit_at(records: list[ActuatorRecord], selection: Selection, form: LawForm, delay: float, starts: np.ndarray,
            fit_offsets: bool) -> tuple[float, np.ndarray, np.ndarray | None]:
    """(RSS, best log parts, Jacobian or None) at a fixed delay [s], the best of least squares from
    each start (rows of ``starts``, log parts). The Jacobian is a forward difference of step 1e-3 in
    each log part (0.1 % of the part), never relative to the log itself, which may be near 0."""
    last: dict[bytes, np.ndarray] = {}

    def fun(x: np.ndarray) -> np.ndarray:
        key = x.tobytes()
        if key not in last:
            last.clear()
            last[key] = _vector(records, selection, _law(form, delay, x), fit_offsets)
        return last[key]

    def jac(x: np.ndarray) -> np.ndarray:
        base = fun(x)
        cols = [(_vector(records, selection, _law(form, delay, x + 1e-3 * e), fit_offsets) - base) / 1e-3
                for e in np.eye(x.size)]
        return np.stack(cols, axis=1)

    if starts.shape[1] == 0:
        r = fun(starts[0])
        return float(r @ r), starts[0], None
    lo = np.log([_BOUNDS[n][0] for n in _free(form)])
    hi = np.log([_BOUNDS[n][1] for n in _free(form)])
    runs = [least_squares(fun, np.clip(x0, lo + 1e-9, hi - 1e-9), jac=jac, bounds=(lo, hi), max_nfev=60)
            for x0 in starts]
    best = min(runs, key=lambda res: float(res.cost))
    return float(2.0 * best.cost), best.x, best.jac


def _starts(records: list[ActuatorRecord], selection: Selection, form: LawForm) -> np.ndarray:
    """Start values (k x p) in log space, every combination of: rate 1.2 and 10 x the 95th percentile
    of the readings' speeds (a limit that binds, one that hardly does), τ = Δ and 10 Δ, slack 1 and
    1.5 x the largest stretch ℓ - R seen (99th percentile: where a tension limit would hold the cables)."""
    speeds = [np.abs(np.diff(r.readings[:, list(c)], axis=0)).ravel() / r.interval
              for r, c in zip(records, selection.cables, strict=True) if c]
    fast = np.concatenate(speeds) if speeds else np.zeros(1)
    fast = fast[np.isfinite(fast)]
    top = float(np.percentile(fast, 95)) if fast.size and np.percentile(fast, 95) > 0 else 1.0
    step = min(r.interval for r in records)
    stretch = [(r.lengths[:, list(c)] - r.readings[:, list(c)]).ravel()
               for r, c in zip(records, selection.cables, strict=True) if c and r.lengths is not None]
    longest = np.concatenate(stretch) if stretch else np.zeros(0)
    longest = longest[np.isfinite(longest)]
    slack = float(np.percentile(longest, 99)) if longest.size and np.percentile(longest, 99) > 0 else 0.05
    values = {"rate": (1.2 * top, 10 * top), "time_constant": (step, 10 * step), "tension_slack": (slack, 1.5 * slack)}
    names = _free(form)
    if not names:
        return np.zeros((1, 0))
    grid = np.array(np.meshgrid(*[values[n] for n in names], indexing="ij")).reshape(len(names), -1).T
    lo = np.array([_BOUNDS[n][0] for n in names]) * 2
    hi = np.array([_BOUNDS[n][1] for n in names]) / 2
    return np.log(np.clip(grid, lo, hi))


def _profile(records: list[ActuatorRecord], selection: Selection, form: LawForm, delays: np.ndarray,
             starts: np.ndarray, fit_offsets: bool) -> list[tuple[float, float, np.ndarray]]:
    """(delay, RSS, log parts) at each delay of ``delays`` (increasing): the first from every start,
    each next one warm-started from the previous, clipped to within a factor 3 of the starts' range:
    a part driven where it no longer acts (a rate limit that never binds, a lag far below Δ) has a
    flat residual and would keep the next fit from coming back."""
    out = []
    low, high = starts.min(axis=0) - math.log(3.0), starts.max(axis=0) + math.log(3.0)
    for d in delays:
        rss, x, _ = _fit_at(records, selection, form, float(d), starts, fit_offsets)
        out.append((float(d), rss, x))
        starts = np.clip(x, low, high)[None, :]
    return out


def fit_form(records: list[ActuatorRecord], selection: Selection, form: LawForm, options: FitOptions, *,
             around: float | None = None, start: np.ndarray | None = None) -> FormFit:
    """Fit ``form`` (module docstring). The delay grid (:func:`_delay_points`): whole samples of the
    shortest interval Δ from 0 to ``max_delay`` [s], then steps of ``fine_step`` Δ within one Δ of the
    best whole sample; given ``around`` [s], a few points near it. ``start``: the log parts to start
    from (p,), else several (:func:`_starts`)."""
    fit_offsets = options.offsets
    step = min(r.interval for r in records)
    starts = _starts(records, selection, form) if start is None else np.asarray(start, float)[None, :]
    if not form.delay:
        points = _profile(records, selection, form, np.zeros(1), starts, fit_offsets)
    else:
        points = _delay_points(records, selection, form, starts, options, step, around)
    best_d, _, best_x = min(points, key=lambda p: p[1])
    rss, best_x, jac = _fit_at(records, selection, form, best_d, best_x[None, :], fit_offsets)
    law = _law(form, best_d, best_x)
    residuals, offsets = evaluate(records, selection, law, fit_offsets)
    n_eff, _ = _effective(residuals)
    n = int(sum(np.isfinite(r).sum() for r in residuals))
    log_sd = _log_sd(form, jac, rss, n_eff)
    law = replace(law, offsets=tuple(float(o) for o in offsets)) if fit_offsets else law
    profile = (np.array([p[0] for p in points]), np.array([rss if p[0] == best_d else p[1] for p in points]))
    return FormFit(law, rss, n, n_eff, profile, log_sd, offset_sd(residuals, selection), residuals, best_x)


def _delay_points(records: list[ActuatorRecord], selection: Selection, form: LawForm, starts: np.ndarray,
                  options: FitOptions, step: float, around: float | None) -> list[tuple[float, float, np.ndarray]]:
    """The delay profile (sorted by delay): whole samples 0..max_delay, then steps of ``fine_step`` Δ
    within Δ of the best (started afresh there from every start as well); given ``around`` [s],
    only around ± (0, ¼, ½, 1) Δ (held-out refits)."""
    fit_offsets, max_delay, fine_step = options.offsets, options.max_delay, options.fine_step
    if around is not None:
        grid = np.unique(np.maximum(around + step * np.array([-1, -0.5, -0.25, 0, 0.25, 0.5, 1]), 0.0))
        return _profile(records, selection, form, grid, starts, fit_offsets)
    whole = np.arange(0, int(math.floor(max_delay / step + 1e-9)) + 1) * step
    points = _profile(records, selection, form, whole, starts, fit_offsets)
    best_d, _, best_x = min(points, key=lambda p: p[1])
    again = _profile(records, selection, form, np.array([best_d]), np.vstack([best_x, starts]), fit_offsets)
    points = [p for p in points if p[0] != best_d] + again
    fine = np.arange(max(0.0, best_d - step), best_d + step + 1e-12, fine_step * step)
    fine = fine[np.min(np.abs(fine[:, None] - whole[None, :]), axis=1) > 1e-9 * step]
    below, above = fine[fine < best_d], fine[fine > best_d]
    points += _profile(records, selection, form, below[::-1], again[0][2][None, :], fit_offsets)
    points += _profile(records, selection, form, above, again[0][2][None, :], fit_offsets)
    return sorted(points, key=lambda p: p[0])


def _effective(residuals: tuple[np.ndarray, ...]) -> tuple[float, list[np.ndarray]]:
    """n_eff over all pairs and, per record, each cable's (AR(1), module docstring)."""
    total, per = 0.0, []
    for e in residuals:
        now, nxt = e[:-1], e[1:]
        both = np.isfinite(now) & np.isfinite(nxt)
        num = np.where(both, now * nxt, 0.0).sum(axis=0)
        den = np.where(np.isfinite(e), e * e, 0.0).sum(axis=0)
        rho = np.clip(np.divide(num, den, out=np.zeros_like(num), where=den > 0), 0.0, 0.99)
        n = np.isfinite(e).sum(axis=0)
        eff = np.clip(n * (1 - rho) / (1 + rho), 1.0, np.maximum(n, 1))
        per.append(eff)
        total += float(eff.sum())
    return total, per


def _log_sd(form: LawForm, jac: np.ndarray | None, rss: float, n_eff: float) -> dict[str, float]:
    """Gauss-Newton sd of each free part's log (module docstring); inf where J has no information."""
    names = _free(form)
    if jac is None or not names:
        return {}
    scale = rss / max(n_eff - len(names), 1.0)
    jtj = jac.T @ jac
    cov = np.linalg.pinv(jtj) * scale
    info = np.diag(jtj)
    return {n: float(math.sqrt(cov[i, i])) if info[i] > 1e-12 * max(info.max(), 1e-300) else math.inf
            for i, n in enumerate(names)}


def offset_sd(residuals: tuple[np.ndarray, ...], selection: Selection) -> np.ndarray:
    """sd (24,) [m] of each cable's offset: σ_j / sqrt(n_eff,j), pooled over records; NaN if not fitted."""
    _, pair_eff = _effective(residuals)
    sq, count, eff = np.zeros(24), np.zeros(24), np.zeros(24)
    for e, cables, n_eff in zip(residuals, selection.cables, pair_eff, strict=True):
        cols = list(cables)
        np.add.at(sq, cols, np.nansum(e * e, axis=0))
        np.add.at(count, cols, np.isfinite(e).sum(axis=0))
        np.add.at(eff, cols, n_eff)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, np.sqrt(sq / np.maximum(count, 1)) / np.sqrt(np.maximum(eff, 1)), np.nan)
