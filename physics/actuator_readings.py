"""The actuator read from the encoders: the law from commands to rest-length readings, before any dynamics.

When trajectories carry ``rest_length`` (the motors' encoder readings, docs/data-format.md), the
actuator's law can be measured from ``controls`` -> ``rest_length`` alone, without simulating the
robot: :func:`identify_actuator` fits every candidate law of physics.actuator_laws (a delay, a rate
limit, a first-order lag, each combination; per-cable offsets) by least squares
(physics.actuator_fitting) over the actuated cables (those whose command moves), chooses between
them by held-out fit, tries a tension limit on the winner (from the observed cable lengths), and
says what it found in plain words (:meth:`ActuatorFit.describe`).

- Held out: the (trajectory, cable) pairs are dealt round-robin into ``folds``; each form is fitted on
  the others and scored on them (RSS). The winner is the simplest form (fewest parts) whose held-out
  RSS is within ``parsimony`` of the best: a part must earn its place on readings it did not see.
  (With one actuated cable nothing can be held out; the in-sample RSS (1 + 2 p / n_eff) stands in.)
  A tension limit joins the winner only when it lowers the held-out RSS by more than ``parsimony``.
- A delay is *claimed* only when the winner has one and its profile interval excludes 0 with a lag
  fitted beside it (the winner's form plus a delay and a lag): a lag smooths a step much as a delay
  shifts it, and only a delay that survives the lag is one. Otherwise the law is the winner without
  its delay, and the delay's interval (always reported) bounds what the readings allow. The reported
  interval covers both the winner's and the lag-beside profile intervals.
- Readings that contradict every law get a named finding, not a fit: a cable whose reading barely
  moves while its command does (``actuator_stuck_cable``: left out of the fit; when most cables are
  stuck, nothing is fitted) and readings the best law explains less than ``min_r2`` of
  (``actuator_readings_do_not_follow``: noise, another robot's log, a wrong cable order).
- Samples: each trajectory is put on its regular clock (physics.trajectory.regular_clock: jitter
  snapped, dropped frames as NaN rows); a sample with a NaN reading or command is not compared, and
  a missing command holds the last one sent (the data format's rule).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import xarray as xr

from physics.actuator_fitting import (
    ActuatorRecord,
    FitOptions,
    FormFit,
    Selection,
    evaluate,
    fit_form,
)
from physics.actuator_laws import CANDIDATE_FORMS, LawForm
from physics.actuator_summary import ActuatorFit, Estimate, cable_fit, offset_estimates
from physics.errors import ParameterError, TrajectoryFormatError
from physics.findings import Finding
from physics.geometry import CABLE_NAMES, CABLE_NODES
from physics.trajectory import regular_clock, validate_trajectory

__all__ = ["ActuatorConfig", "ActuatorReadingsError", "actuator_record", "identify_actuator"]


class ActuatorReadingsError(TrajectoryFormatError):
    """A trajectory cannot be read for its actuator: it has no ``rest_length`` (encoder readings)."""


@dataclass(frozen=True, kw_only=True)
class ActuatorConfig:
    """Options of :func:`identify_actuator`.

    max_delay [s]: the delay grid's end; fine_step: the fine delay grid's step [samples];
    folds: held-out folds over (trajectory, cable) pairs; parsimony: the relative held-out RSS a
    form with more parts must gain; offsets: fit one offset per cable; tension_limit: try a tension
    limit on the winner (needs node positions); stiffness [N/m]: the cable stiffness k, to turn the
    slack s into maxTens = k s (None: s only); min_command_change [m]: a cable is actuated when its
    command's range exceeds it; stuck_fraction: a cable is stuck when its reading's range (1st to
    99th percentile) is below this fraction of its command's; min_r2: the held-out share of the
    readings' variance the law must explain; min_offset [m] and offset_z: an offset is reported
    when it exceeds both min_offset and offset_z sd; misfit_ratio and misfit_rms [m]: the law is
    reported as a misfit when n_eff / n lies below misfit_ratio (residuals correlated over more
    than 1 / misfit_ratio samples) and the RMS residual exceeds misfit_rms (below it the law follows
    the readings about as closely as marker positions give the cable lengths its tension limit
    reads, so a correlated remainder says nothing about the actuator); level: the intervals' coverage.
    """

    max_delay: float = 0.2
    fine_step: float = 0.1
    folds: int = 4
    parsimony: float = 0.03
    offsets: bool = True
    tension_limit: bool = True
    stiffness: float | None = None
    min_command_change: float = 1e-3
    stuck_fraction: float = 0.1
    min_r2: float = 0.5
    min_offset: float = 2e-3
    offset_z: float = 3.0
    misfit_ratio: float = 0.2
    misfit_rms: float = 1e-3
    level: float = 0.95

    def __post_init__(self) -> None:
        positive = ("max_delay", "fine_step", "min_command_change", "stuck_fraction", "min_offset", "offset_z",
                    "misfit_rms")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ParameterError(f"ActuatorConfig.{name} must be a finite number > 0, got {value!r}.")
        if not (isinstance(self.folds, int) and self.folds >= 2):
            raise ParameterError(f"ActuatorConfig.folds must be an integer >= 2, got {self.folds!r}.")
        for name in ("parsimony", "min_r2", "misfit_ratio", "level"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and 0 <= value < 1):
                raise ParameterError(f"ActuatorConfig.{name} must lie in [0, 1), got {value!r}.")
        if self.stiffness is not None and not (math.isfinite(self.stiffness) and self.stiffness > 0):
            raise ParameterError(f"ActuatorConfig.stiffness must be a cable stiffness > 0 N/m or None, "
                                 f"got {self.stiffness!r}.")
        if self.fine_step >= 1:
            raise ParameterError(f"ActuatorConfig.fine_step must be a fraction of a sample < 1, "
                                 f"got {self.fine_step!r}.")


def actuator_record(ds: xr.Dataset, *, name: str = "") -> ActuatorRecord:
    """The actuator data of one trajectory on its regular clock (:class:`ActuatorRecord`); raises
    :class:`ActuatorReadingsError` without ``rest_length``."""
    if not isinstance(ds, xr.Dataset) or "rest_length" not in ds.data_vars:
        raise ActuatorReadingsError(f"trajectory {name or '?'} has no 'rest_length' (encoder readings) to read the "
                                    "actuator from; record the motors' encoder readings as rest_length "
                                    "(docs/data-format.md) or leave the actuator to the dynamics.")
    ds = validate_trajectory(regular_clock(ds, source=name or None), source=name or None)
    time = np.asarray(ds["time"].values, float)
    commands = np.asarray(ds["controls"].transpose("time", "cable").values, float)
    readings = np.asarray(ds["rest_length"].transpose("time", "cable").values, float)
    compared = np.isfinite(commands) & np.isfinite(readings)
    nodes = np.asarray(ds["nodes"].values, float)
    lengths = np.linalg.norm(nodes[:, CABLE_NODES[:, 0]] - nodes[:, CABLE_NODES[:, 1]], axis=2)
    return ActuatorRecord(_held(commands), readings, compared, lengths, float(np.median(np.diff(time))), name)


def _held(commands: np.ndarray) -> np.ndarray:
    """Commands (T x m) with each missing one replaced by the last sent (before the first: the first
    sent; a cable never commanded: 0, never compared)."""
    out = commands.copy()
    for j in range(out.shape[1]):
        ok = np.isfinite(out[:, j])
        if not ok.any():
            out[:, j] = 0.0
            continue
        index = np.where(ok, np.arange(out.shape[0]), 0)
        np.maximum.accumulate(index, out=index)
        index[: int(np.argmax(ok))] = int(np.argmax(ok))
        out[:, j] = out[index, j]
    return out


def _split_cables(records: list[ActuatorRecord], config: ActuatorConfig
                  ) -> tuple[list[list[int]], list[list[int]], list[Finding]]:
    """Per record: the actuated cables that follow, the stuck ones; a finding per stuck cable."""
    following, stuck, findings = [], [], []
    for rec in records:
        moving, frozen = [], []
        for j in range(24):
            ok = rec.compared[:, j]
            if ok.sum() < 3:
                continue
            span = float(np.ptp(rec.commands[ok, j]))
            if span <= config.min_command_change:
                continue
            lo, hi = np.percentile(rec.readings[ok, j], [1, 99])
            if hi - lo < config.stuck_fraction * span:
                frozen.append(j)
                findings.append(Finding(
                    "actuator_stuck_cable", "warning",
                    f"{rec.name or 'trajectory'}: cable {CABLE_NAMES[j]}'s reading moves {1e3 * (hi - lo):.1f} mm "
                    f"while its command moves {1e3 * span:.0f} mm: a stuck cable or a dead encoder; left out of "
                    "the fit.",
                    "check the motor and its encoder, or drop the cable's readings (NaN)."))
            else:
                moving.append(j)
        following.append(moving)
        stuck.append(frozen)
    return following, stuck, findings


def _not_following(message: str) -> Finding:
    return Finding("actuator_readings_do_not_follow", "error", message,
                   "check that rest_length holds this robot's encoder readings, in the cables' order and in metres.")


def identify_actuator(trajectories: Sequence[xr.Dataset | ActuatorRecord],
                      config: ActuatorConfig | None = None) -> ActuatorFit:
    """The actuator law of ``trajectories`` read from their commands and encoder readings (module
    docstring): the chosen law with intervals, per-cable fit and offsets, and findings; a fit without
    a law (``law`` None) and a named finding when the readings contradict every law."""
    config = config or ActuatorConfig()
    if not trajectories:
        raise ParameterError("identify_actuator needs at least one trajectory with rest_length readings.")
    records = [t if isinstance(t, ActuatorRecord) else actuator_record(t, name=f"t{k}")
               for k, t in enumerate(trajectories)]
    following, stuck, findings = _split_cables(records, config)
    statics = Selection(tuple(tuple(j for j in range(24) if j not in f + s and r.compared[:, j].any())
                              for r, f, s in zip(records, following, stuck, strict=True)))
    n_follow, n_stuck = sum(map(len, following)), sum(map(len, stuck))
    empty = ActuatorFit.empty(records, statics, config.offsets, tuple(findings))
    if n_follow + n_stuck == 0:
        return replace(empty, findings=empty.findings + (Finding(
            "actuator_no_commands", "warning", "no cable's command moves by more than "
            f"{1e3 * config.min_command_change:g} mm, so the readings cannot show how the actuators follow.",
            "record a trajectory that moves the cables (a flop)."),))
    if n_stuck > n_follow:
        return replace(empty, findings=empty.findings + (_not_following(
            f"{n_stuck} of {n_stuck + n_follow} actuated cables read (nearly) constant while their commands move: "
            "the readings do not follow the commands, so no law is fitted."),))
    selection = Selection(tuple(tuple(f) for f in following))
    return _fit_laws(records, selection, Selection(tuple(tuple(s) for s in stuck)), statics, config,
                     tuple(findings), empty)


def _choose(scores: dict[LawForm, float], parsimony: float) -> LawForm:
    """The simplest form whose held-out RSS is within ``parsimony`` of the best (then the lowest RSS)."""
    best = min(scores.values())
    near = [f for f, s in scores.items() if s <= best * (1 + parsimony)]
    return min(near, key=lambda f: (f.size, scores[f]))


def _fit_laws(records: list[ActuatorRecord], selection: Selection, stuck: Selection, statics: Selection,
              config: ActuatorConfig, findings: tuple[Finding, ...], empty: ActuatorFit) -> ActuatorFit:
    """Fit and score every candidate form, choose, try a tension limit, claim a delay, summarise."""
    kw = FitOptions(max_delay=config.max_delay, fine_step=config.fine_step, offsets=config.offsets)
    fits = {form: fit_form(records, selection, form, kw) for form in CANDIDATE_FORMS}
    scores = {form: _score(records, selection, fit, kw, config.folds) for form, fit in fits.items()}
    total = _spread(records, selection)
    winner = _choose(scores, config.parsimony)
    r2 = 1.0 - scores[winner] / total if total > 0 else 0.0
    if r2 < config.min_r2:
        return replace(empty, findings=findings + (_not_following(
            f"the best actuator law ({winner.name}) explains {max(r2, 0):.0%} of the held-out readings' variance "
            f"(at least {config.min_r2:.0%} needed): the readings do not follow the commands, so no law is fitted."),))
    best = fits[winner]
    if config.tension_limit and all(r.lengths is not None for r in records):
        tense = replace(winner, tension_limit=True)
        tense_fit = fit_form(records, selection, tense, kw)
        score = _score(records, selection, tense_fit, kw, config.folds)
        scores[tense] = score
        if score < scores[winner] * (1 - config.parsimony):
            best, winner = tense_fit, tense
    claim = _claim_fit(records, selection, best, fits, kw)
    delay = _delay_estimate(best, claim, config.level)
    claimed = winner.delay and delay.low > 0
    if winner.delay and not claimed:          # the same law without the delay it cannot tell from 0
        winner = replace(winner, delay=False)
        best = fits.get(winner) or fit_form(records, selection, winner, kw)
    return _summarise(records, selection, stuck, statics, best, scores, delay, claimed, config, findings)


def _score(records: list[ActuatorRecord], selection: Selection, fit: FormFit, kw: FitOptions, folds: int) -> float:
    """The held-out RSS [m²] of a fitted form (:func:`_held_out_rss`); with a single
    actuated cable nothing can be held out, and the in-sample RSS (1 + 2 p / n_eff) stands in for it
    (Akaike's estimate of the prediction error, p the fitted parts counting the delay)."""
    if len(selection.pairs()) >= 2:
        return _held_out_rss(records, selection, fit.law.form, kw, folds=folds, around=fit.law.delay,
                            start=fit.log_parts)
    parts = fit.log_parts.size + int(fit.law.form.delay)
    return fit.rss * (1.0 + 2.0 * parts / max(fit.n_eff, 1.0))


def _spread(records: list[ActuatorRecord], selection: Selection) -> float:
    """Σ over fitted pairs of the readings' squared deviation from their mean [m²] (R² = 0: commands ignored)."""
    total = 0.0
    for rec, cables in zip(records, selection.cables, strict=True):
        for j in cables:
            r = rec.readings[rec.compared[:, j], j]
            total += float(((r - r.mean()) ** 2).sum())
    return total


def _claim_fit(records: list[ActuatorRecord], selection: Selection, best: FormFit, fits: dict[LawForm, FormFit],
               kw: FitOptions) -> FormFit:
    """The fit whose delay interval decides a claim (and bounds the delay when none is claimed): the
    winner's form with a delay and a lag fitted beside it."""
    form = replace(best.law.form, delay=True, lag=True)
    if form == best.law.form:
        return best
    return fits.get(form) or fit_form(records, selection, form, kw)


def _delay_estimate(best: FormFit, claim: FormFit, level: float) -> Estimate:
    """The winner's delay [s] (the claim fit's when the winner has none) and the interval covering both
    fits' profile intervals: with a lag beside it, a fraction of a sample may be as well a lag."""
    low, high = claim.delay_interval(level)
    if not best.law.form.delay:
        return Estimate(claim.law.delay, low, high, "s")
    own_low, own_high = best.delay_interval(level)
    return Estimate(best.law.delay, min(low, own_low), max(high, own_high), "s")


def _summarise(records: list[ActuatorRecord], selection: Selection, stuck: Selection, statics: Selection,
               best: FormFit, scores: dict[LawForm, float], delay: Estimate, claimed: bool,
               config: ActuatorConfig, findings: tuple[Finding, ...]) -> ActuatorFit:
    """The :class:`ActuatorFit` of the winner: estimates, per-cable fit and offsets, findings."""
    law = best.law
    parts = {name: Estimate(getattr(law, name), *best.part_interval(name, getattr(law, name), config.level), unit)
             for name, unit, on in (("rate", "m/s", law.form.rate_limit), ("time_constant", "s", law.form.lag),
                                    ("tension_slack", "m", law.form.tension_limit)) if on}
    slack, k = parts.get("tension_slack"), config.stiffness
    max_tension = None if slack is None or k is None else Estimate(k * slack.value, k * slack.low, k * slack.high, "N")
    rms, r2 = cable_fit(records, selection, best.residuals)
    stuck_res, _ = evaluate(records, stuck, replace(law, offsets=()), config.offsets)
    stuck_rms, _ = cable_fit(records, stuck, stuck_res)
    offsets, offset_sd, static_rms = offset_estimates(records, statics, best, config.offsets)
    rms = np.where(np.isfinite(stuck_rms), stuck_rms, rms)
    rms = np.where(np.isfinite(static_rms) & ~np.isfinite(rms), static_rms, rms)
    flagged = tuple(int(j) for j in np.flatnonzero(np.abs(np.nan_to_num(offsets)) > np.maximum(
        config.min_offset, config.offset_z * np.nan_to_num(offset_sd, nan=np.inf)))) if config.offsets else ()
    findings = findings + _cable_findings(rms, r2, offsets, offset_sd, flagged, config) + _misfit(best, config)
    held = tuple((form.name, float(score)) for form, score in sorted(scores.items(), key=lambda p: p[1]))
    return ActuatorFit(law=law, form=law.form.name, delay=delay, delay_claimed=claimed,
                       rate=parts.get("rate"), time_constant=parts.get("time_constant"), tension_slack=slack,
                       max_tension=max_tension, offsets=offsets, offset_sd=offset_sd, offset_cables=flagged,
                       cable_rms=rms, cable_r2=r2, actuated=tuple(sorted({j for c in selection.cables for j in c})),
                       held_out=held, rms=math.sqrt(best.rss / max(best.n, 1)),
                       interval=min(r.interval for r in records), findings=findings)


def _cable_findings(rms: np.ndarray, r2: np.ndarray, offsets: np.ndarray, offset_sd: np.ndarray,
                    flagged: tuple[int, ...], config: ActuatorConfig) -> tuple[Finding, ...]:
    """A warning per actuated cable the law explains poorly, an info per offset cable."""
    poor = tuple(
        Finding("actuator_cable_off_law", "warning",
                f"cable {CABLE_NAMES[j]} follows the law poorly ({r2[j]:.0%} of its readings' variance explained, "
                f"{1e3 * rms[j]:.1f} mm RMS).", "look at its readings against its commands.")
        for j in range(24) if np.isfinite(r2[j]) and r2[j] < config.min_r2)
    return poor + tuple(
        Finding("actuator_offset_cable", "info",
                f"cable {CABLE_NAMES[j]} reads {1e3 * offsets[j]:+.1f} ± {1e3 * offset_sd[j]:.1f} mm off the "
                "command it reaches: a mis-zeroed encoder.", "re-zero the encoder, or keep the offset in the model.")
        for j in flagged)


def _misfit(best: FormFit, config: ActuatorConfig) -> tuple[Finding, ...]:
    """A warning when the winner's residuals stay correlated over more than 1 / misfit_ratio samples
    and their RMS exceeds misfit_rms [m] (ActuatorConfig)."""
    rms = math.sqrt(best.rss / max(best.n, 1))
    if best.n_eff >= config.misfit_ratio * best.n or rms <= config.misfit_rms:
        return ()
    return (Finding(
        "actuator_law_misfit", "warning",
        f"the chosen law ({best.law.form.name}) leaves a misfit that persists over "
        f"~{best.n / max(best.n_eff, 1.0):.0f} samples ({1e3 * rms:.2g} mm RMS): "
        "the actuator does something no candidate law does (a load-dependent droop, motor inertia); its "
        "intervals are widened for it.",
        "compare the readings with the law's prediction per cable."),)


def _held_out_rss(records: list[ActuatorRecord], selection: Selection, form: LawForm, options: FitOptions, *,
                  folds: int, around: float | None, start: np.ndarray | None) -> float:
    """Σ over ``folds`` of the RSS [m²] on held-out (record, cable) pairs of ``form`` fitted on the others
    (pairs dealt round-robin to folds; the held-out cables' offsets are profiled on their own readings,
    the same for every form, so only the law's shared parts are judged held out). ``around`` and
    ``start``: the delay [s] and log parts of the fit on all pairs, where each refit starts."""
    pairs = selection.pairs()
    k = max(2, min(folds, len(pairs)))
    total = 0.0
    for f in range(k):
        test = pairs[f::k]
        train = [p for p in pairs if p not in test]
        if not test or not train:
            continue
        fitted = fit_form(records, Selection.of(train, len(records)), form, options, around=around, start=start)
        law = replace(fitted.law, offsets=())
        residuals, _ = evaluate(records, Selection.of(test, len(records)), law, options.offsets)
        total += float(np.nansum(np.concatenate([r.ravel() for r in residuals]) ** 2))
    return total
