"""What the actuator stage found (physics.actuator_readings): the law, its intervals, the fit per cable,
in numbers and in plain words."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from physics.actuator_fitting import ActuatorRecord, FormFit, Selection, evaluate, offset_sd
from physics.actuator_laws import ActuatorLaw, LawForm
from physics.findings import Finding
from physics.geometry import CABLE_NAMES

__all__ = ["Estimate", "ActuatorFit", "cable_fit", "offset_estimates"]


@dataclass(frozen=True)
class Estimate:
    """A fitted value with its interval [low, high] (physics.actuator_fitting says how) in ``unit``."""

    value: float
    low: float
    high: float
    unit: str


@dataclass(frozen=True, eq=False, kw_only=True)
class ActuatorFit:
    """The actuator law read from the encoders.

    ``law``: the chosen law with its values and offsets (None: no law fits, see ``findings``);
    ``form``: its name; ``delay`` [s]: estimate and profile interval with a lag fitted beside it
    (whether or not the law keeps a delay; None without a fit); ``delay_claimed``: the law has a
    delay whose interval excludes 0; ``rate`` [m/s], ``time_constant`` [s], ``tension_slack``
    s = maxTens / k [m], ``max_tension`` [N] (given k): estimates of the parts the law has, else
    None; ``offsets``, ``offset_sd`` (24,) [m] (NaN: cable without readings); ``offset_cables``: the
    cables whose offset is reported; ``cable_rms`` (24,) [m] RMS residual per cable; ``cable_r2``
    (24,) the share of an actuated cable's reading variance the law explains (NaN: not actuated);
    ``actuated``: the cables fitted; ``held_out``: (form, held-out RSS [m²]) best first; ``rms`` [m]
    over the fitted cables; ``interval`` [s] the shortest sample interval; ``findings``.
    """

    law: ActuatorLaw | None
    form: str
    delay: Estimate | None
    delay_claimed: bool
    rate: Estimate | None
    time_constant: Estimate | None
    tension_slack: Estimate | None
    max_tension: Estimate | None
    offsets: np.ndarray
    offset_sd: np.ndarray
    offset_cables: tuple[int, ...]
    cable_rms: np.ndarray
    cable_r2: np.ndarray
    actuated: tuple[int, ...]
    held_out: tuple[tuple[str, float], ...]
    rms: float
    interval: float
    findings: tuple[Finding, ...]

    @classmethod
    def empty(cls, records: list[ActuatorRecord], statics: Selection, fit_offsets: bool,
              findings: tuple[Finding, ...]) -> ActuatorFit:
        """A fit without a law: only the offsets of the cables whose command stays put."""
        immediate = FormFit(ActuatorLaw(form=LawForm()), 0.0, 0, 0.0, (np.zeros(1), np.zeros(1)), {},
                            np.full(24, np.nan), (), np.zeros(0))
        offsets, sd, rms = offset_estimates(records, statics, immediate, fit_offsets)
        return cls(law=None, form="none", delay=None, delay_claimed=False, rate=None, time_constant=None,
                   tension_slack=None, max_tension=None, offsets=offsets, offset_sd=sd, offset_cables=(),
                   cable_rms=rms, cable_r2=np.full(24, np.nan), actuated=(), held_out=(), rms=math.nan,
                   interval=min(r.interval for r in records), findings=findings)

    @property
    def identified(self) -> bool:
        """Whether a law was fitted."""
        return self.law is not None

    def describe(self) -> str:
        """The law in plain words: "The motors follow their commands 50 ms late, at up to 1.4 m/s. ..."."""
        if self.law is None:
            named = [f for f in self.findings if f.severity == "error"] or list(self.findings)
            return "The actuator law was not identified: " + (named[0].message if named else "no readings to fit.")
        how = [self._delay_words()]
        if self.rate is not None:
            how.append(f"at up to {self.rate.value:.2g} m/s" + _spread(self.rate, 1.0, "m/s"))
        if self.time_constant is not None:
            lag = self.time_constant
            how.append(f"through a {1e3 * lag.value:.0f} ms lag" + _spread(lag, 1e3, "ms"))
        if self.tension_slack is not None:
            limit = f" (maxTens {self.max_tension.value:.0f} N)" if self.max_tension is not None else ""
            how.append(f"never stretching a cable more than {1e3 * self.tension_slack.value:.0f} mm{limit}")
        text = f"The motors follow their commands {', '.join(how)}."
        text += (f" The readings fit to {1e3 * self.rms:.2g} mm RMS ({self.form}, chosen by held-out fit "
                 f"over {len(self.held_out)} laws).")
        for j in self.offset_cables:
            text += (f" Cable {CABLE_NAMES[j]} reads {1e3 * self.offsets[j]:+.1f} mm off its command "
                     "(a mis-zeroed encoder).")
        for f in self.findings:
            if f.code == "actuator_stuck_cable":
                text += " " + f.message
        return text

    def _delay_words(self) -> str:
        d = self.delay
        if d is None:
            return "with no delay measured"
        if self.delay_claimed:
            value = f"{1e3 * d.value:.0f}" if d.value >= 0.0095 else f"{1e3 * d.value:.1f}"
            return (f"{value} ms late ({1e3 * d.low:.1f}-{1e3 * d.high:.1f} ms, {d.value / self.interval:.1f} "
                    "samples)")
        return f"with no delay told from zero (at most {1e3 * d.high:.1f} ms)"

    def cable_lines(self) -> list[str]:
        """One line per cable with readings: name, RMS [mm], share explained, offset ± sd [mm]."""
        lines = []
        for j in range(24):
            if not np.isfinite(self.cable_rms[j]):
                continue
            r2 = f"{self.cable_r2[j]:.1%}" if np.isfinite(self.cable_r2[j]) else "static"
            offset = f"{1e3 * self.offsets[j]:+.2f} ± {1e3 * self.offset_sd[j]:.2f} mm" \
                if np.isfinite(self.offsets[j]) else "-"
            lines.append(f"{CABLE_NAMES[j]}  rms {1e3 * self.cable_rms[j]:.2f} mm  explained {r2}  offset {offset}")
        return lines


def _spread(estimate: Estimate, scale: float, unit: str) -> str:
    """`` (0.8-76 m/s)`` when the interval is wider than ±10 % of the value, else nothing."""
    if estimate.low >= 0.9 * estimate.value and estimate.high <= 1.1 * estimate.value:
        return ""
    high = f"{scale * estimate.high:.3g}" if math.isfinite(estimate.high) else "unbounded"
    return f" ({scale * estimate.low:.3g}-{high} {unit})"


def cable_fit(records: list[ActuatorRecord], selection: Selection, residuals: tuple[np.ndarray, ...]
              ) -> tuple[np.ndarray, np.ndarray]:
    """Per cable, pooled over records: RMS residual (24,) [m] and R² = 1 - Σe² / Σ(R - mean R)² (24,);
    NaN where the cable is not in the selection."""
    sq, count, spread = np.zeros(24), np.zeros(24), np.zeros(24)
    for rec, cables, e in zip(records, selection.cables, residuals, strict=True):
        for col, j in enumerate(cables):
            ok = np.isfinite(e[:, col])
            r = rec.readings[ok, j]
            sq[j] += float((e[ok, col] ** 2).sum())
            count[j] += ok.sum()
            spread[j] += float(((r - r.mean()) ** 2).sum()) if r.size else 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.where(count > 0, np.sqrt(sq / np.maximum(count, 1)), np.nan)
        r2 = np.where((count > 0) & (spread > 0), 1.0 - sq / np.where(spread > 0, spread, 1.0), np.nan)
    return rms, r2


def offset_estimates(records: list[ActuatorRecord], statics: Selection, best: FormFit, fit_offsets: bool
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Offsets (24,) [m] and their sd (24,) [m]: the fitted cables' from ``best``, the static cables'
    (command constant) as mean(reading - command); and the static cables' RMS residual (24,) [m]. NaN
    for cables without either."""
    offsets = np.full(24, np.nan)
    sd = np.asarray(best.offset_sd, float).copy()
    if best.law.offsets:
        fitted = np.isfinite(sd)
        offsets[fitted] = np.asarray(best.law.offsets)[fitted]
    if not any(statics.cables):
        return offsets, sd, np.full(24, np.nan)
    plain = ActuatorLaw(form=LawForm())
    residuals, static_offsets = evaluate(records, statics, plain, fit_offsets)
    static_sd = offset_sd(residuals, statics)
    rms, _ = cable_fit(records, statics, residuals)
    cols = sorted({j for c in statics.cables for j in c})
    offsets[cols] = static_offsets[cols] if fit_offsets else 0.0
    sd[cols] = static_sd[cols]
    return offsets, sd, rms
