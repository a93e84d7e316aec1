"""Actuator laws as the encoders see them: how rest-length readings follow commanded rest lengths.

A law maps the commands c_i (T x m) [m], sampled every Δ [s] and held over [t_i, t_{i+1}) (the
data format's zero-order hold), to the readings R_i (T x m) [m] the encoders report at t_i, through
a chain of up to four parts, per cable j:

    u(t) = max(c_j(t - d) + o_j, ℓ_j(t) - s)    the target the motor acts on
    v    moves toward u at up to r [m/s]         rate limit (r = inf: v = u at once)
    τ dL/dt = v - L                              first-order lag of time constant τ [s] (τ = 0: L = v)
    R_i  = L(t_i)

- delay d [s]: the command is seen d late. As n + f samples (n whole, 0 <= f < 1), over the
  interval [t_i, t_{i+1}) the target is c_{i-n-1} for its first fΔ and c_{i-n} for the rest, and the
  chain is integrated over both parts exactly. A pure delay (no rate limit, no lag: an actuator that
  follows at once) would make f invisible at the samples; its reading is taken linear between the
  two whole-sample predictions instead, R(d) = (1 - f) R(nΔ) + f R((n + 1)Δ), which is what gives a
  fraction of a sample a meaning there;
- offset o_j [m]: the cable's encoder reads o_j off the command it reaches (a mis-zeroed encoder);
- tension limit: the actuator never winds a cable shorter than ℓ_j(t) - s, ℓ the observed cable
  length [m] and s = maxTens / k [m] the stretch at which the tension reaches maxTens (NTRT's basic
  actuator, physics.actuators.tension_limited_step); ℓ is not delayed (it is the cable's state);
- the rate limit acts before the lag: v ramps at r, L follows v with τ, so the reading accelerates
  over ~τ after a step (a motor's inertia) instead of jumping to full speed. A lag alone is the same
  in either order.

With d = 0 the command sent at t_i moves the reading from t_{i+1} on (the reading at t_i was taken
before it). Before t_0 the actuator is taken at rest at its first target: c_{i<0} = c_0 and
L(t_0) = v(t_0) = u(t_0), so without a tension limit an offset adds to the readings exactly,
R(c + o) = R(c) + o (physics.actuator_fitting profiles offsets out in closed form that way). Each
interval is integrated exactly (a ramp, then a constant, through the lag), so the prediction does
not depend on a step size.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from physics.errors import ParameterError

__all__ = ["LawForm", "ActuatorLaw", "CANDIDATE_FORMS", "predict_readings", "chain_readings", "interval_step"]


@dataclass(frozen=True, kw_only=True)
class LawForm:
    """Which parts a law has (module docstring): a delay, a rate limit, a lag, a tension limit.
    A form without any part reads the command one sample after it was sent."""

    delay: bool = False
    rate_limit: bool = False
    lag: bool = False
    tension_limit: bool = False

    @property
    def parts(self) -> tuple[str, ...]:
        """The names of its parts, in chain order."""
        named = (("delay", self.delay), ("rate limit", self.rate_limit), ("lag", self.lag),
                 ("tension limit", self.tension_limit))
        return tuple(name for name, present in named if present)

    @property
    def name(self) -> str:
        """``"delay + rate limit"``, ...; ``"immediate"`` for the form without parts."""
        return " + ".join(self.parts) or "immediate"

    @property
    def size(self) -> int:
        """Its number of parts (a simpler form has fewer)."""
        return len(self.parts)


#: Every form with a delay, a rate limit and a lag or not (7, simplest first): the laws the stage
#: chooses between by held-out fit. The tension limit is tried on the winner (physics.actuator_readings).
CANDIDATE_FORMS: tuple[LawForm, ...] = tuple(
    sorted((LawForm(delay=d, rate_limit=r, lag=g) for d in (False, True) for r in (False, True)
            for g in (False, True) if d or r or g), key=lambda f: (f.size, f.name)))


@dataclass(frozen=True, kw_only=True)
class ActuatorLaw:
    """A law of a form at its values: ``delay`` d [s] >= 0, ``rate`` r [m/s] (inf: none),
    ``time_constant`` τ [s] (0: none), ``tension_slack`` s = maxTens / k [m] (inf: none), ``offsets``
    o_j [m] per cable (empty: none). A part the form lacks must sit at its off value."""

    form: LawForm
    delay: float = 0.0
    rate: float = math.inf
    time_constant: float = 0.0
    tension_slack: float = math.inf
    offsets: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        checks = (("delay", self.delay, self.form.delay, 0.0, "d >= 0 s"),
                  ("rate", self.rate, self.form.rate_limit, math.inf, "r > 0 m/s"),
                  ("time_constant", self.time_constant, self.form.lag, 0.0, "τ >= 0 s"),
                  ("tension_slack", self.tension_slack, self.form.tension_limit, math.inf, "s > 0 m"))
        for name, value, present, off, rule in checks:
            if not present and value != off:
                raise ParameterError(f"ActuatorLaw.{name} = {value!r} but the form {self.form.name!r} has no "
                                     f"such part; leave it at {off} or add the part to the form.")
            bad = value < 0 if name in ("delay", "time_constant") else value <= 0
            if math.isnan(value) or bad or (name in ("delay", "time_constant") and math.isinf(value)):
                raise ParameterError(f"ActuatorLaw.{name} must satisfy {rule}, got {value!r}.")
        if not all(math.isfinite(o) for o in self.offsets):
            raise ParameterError("ActuatorLaw.offsets must be finite numbers [m]; use () for no offsets.")

    def predict(self, commands: np.ndarray, interval: float, lengths: np.ndarray | None = None) -> np.ndarray:
        """Readings (T x m) [m] from commands (T x m) [m] sampled every ``interval`` [s]; ``lengths``
        (T x m) [m] the observed cable lengths, needed by a tension limit (NaN: no limit there)."""
        commands = np.asarray(commands, float)
        offsets = np.asarray(self.offsets, float) if self.offsets else np.zeros(commands.shape[1])
        if offsets.shape != (commands.shape[1],):
            raise ParameterError(f"ActuatorLaw has {offsets.size} offsets for {commands.shape[1]} cables; "
                                 "give one per cable (or none).")
        if self.form.tension_limit and lengths is None:
            raise ParameterError("a tension-limited law needs the observed cable lengths; pass lengths (T x m).")
        floor = None if not self.form.tension_limit else np.asarray(lengths, float) - self.tension_slack
        return predict_readings(commands + offsets, interval, delay=self.delay, rate=self.rate,
                                time_constant=self.time_constant, floor=floor)


def predict_readings(targets: np.ndarray, interval: float, *, delay: float, rate: float, time_constant: float,
                     floor: np.ndarray | None) -> np.ndarray:
    """Readings (T x m) [m] of the chain (module docstring) for targets c + o (T x m) [m], finite,
    sampled every ``interval`` Δ [s]; ``floor`` (T x m) [m] ℓ - s or None (NaN: no floor)."""
    targets = np.ascontiguousarray(targets, dtype=float)
    if targets.ndim != 2 or not np.all(np.isfinite(targets)):
        raise ParameterError(f"targets must be a finite (T x m) array [m], got shape {targets.shape}; "
                             "fill missing commands with the last one sent (they are held).")
    if not (interval > 0 and math.isfinite(interval)):
        raise ParameterError(f"the sample interval must be > 0 s, got {interval!r}.")
    floors = None if floor is None else np.ascontiguousarray(np.where(np.isfinite(floor), floor, -np.inf), float)
    return chain_readings(targets, floors, interval, delay, rate, time_constant)


def chain_readings(targets: np.ndarray, floors: np.ndarray | None, interval: float, delay: float, rate: float,
                   time_constant: float) -> np.ndarray:
    """:func:`predict_readings` without its checks (the fitting loop's inner call): targets (T x m)
    finite and C-contiguous, floors (T x m) with -inf for none, or None."""
    if floors is None:
        floors = np.full(targets.shape, -np.inf)
    steps = delay / interval
    whole = int(math.floor(steps + 1e-9))
    frac = max(0.0, steps - whole)
    if math.isinf(rate) and time_constant <= 0 and frac > 1e-9:      # pure delay: linear between samples
        return ((1.0 - frac) * _predict(targets, floors, whole, 0.0, rate, time_constant, interval)
                + frac * _predict(targets, floors, whole + 1, 0.0, rate, time_constant, interval))
    return _predict(targets, floors, whole, frac if frac > 1e-9 else 0.0, rate, time_constant, interval)


def _predict(targets: np.ndarray, floors: np.ndarray, shift: int, frac: float, rate: float, tau: float,
             interval: float) -> np.ndarray:
    """The chain with a delay of ``shift`` + ``frac`` samples: over interval i the target is
    c_{i-shift-1} for frac Δ, then c_{i-shift} (c_{i<0} = c_0)."""
    rows = np.arange(targets.shape[0])
    late = np.ascontiguousarray(targets[np.maximum(rows - shift, 0)])
    early = np.ascontiguousarray(targets[np.maximum(rows - shift - 1, 0)]) if frac > 0 else late
    out = np.empty_like(targets)
    _chain(early, late, floors, float(rate), float(tau), frac * float(interval), (1.0 - frac) * float(interval), out)
    return out


@njit(cache=True)
def interval_step(v: float, lag_state: float, u: float, rate: float, tau: float, h: float) -> tuple[float, float]:
    """(v, L) after one interval h [s] with target u held: v ramps toward u at up to ``rate``
    (a ramp of slope ±rate for a = min(|u - v| / rate, h), then constant), L follows v through the
    lag τ exactly: on a ramp v0 + σt, L(t) = v(t) - στ + (L0 - v0 + στ) e^(-t/τ)."""
    if math.isinf(rate):
        a, slope, v_end = 0.0, 0.0, u
    else:
        gap = u - v
        slope = rate if gap > 0 else -rate
        a = abs(gap) / rate
        if a >= h:
            a, v_end = h, v + slope * h
        else:
            v_end = u
    if tau <= 0.0:
        return v_end, v_end
    lag = lag_state
    if a > 0.0:
        lag = v_end - slope * tau + (lag - v + slope * tau) * math.exp(-a / tau)
    if a < h:
        lag = v_end + (lag - v_end) * math.exp(-(h - a) / tau)
    return v_end, lag


@njit(cache=True)
def _chain(early: np.ndarray, late: np.ndarray, floors: np.ndarray, rate: float, tau: float, h_early: float,
           h_late: float, out: np.ndarray) -> None:
    """Fill ``out`` (T x m) with the readings of the chain: over interval i the target is early[i]
    for h_early [s], then late[i] for h_late [s], each floored by floors[i] (-inf: none); each cable
    starts at rest at its first (floored) target."""
    n, m = late.shape
    for j in range(m):
        u = max(late[0, j], floors[0, j])
        v, lag = u, u
        out[0, j] = u
        for i in range(n - 1):
            if h_early > 0.0:
                v, lag = interval_step(v, lag, max(early[i, j], floors[i, j]), rate, tau, h_early)
            v, lag = interval_step(v, lag, max(late[i, j], floors[i, j]), rate, tau, h_late)
            out[i + 1, j] = lag
