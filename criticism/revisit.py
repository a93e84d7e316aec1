"""A second look at the mismatch stage once criticism has a suspect.

The stage decides each component change on the model it has (criticism.mismatch). When the data
carry an effect the model lacks, a component whose law is right can still fit worse without it:
a cable hysteresis nobody modelled softens the cables while the actuators reel them in, which is
the tension the tension-limited actuator's law reads, so that actuator loses to DART's motors
and the stage rejects it. Criticism then ranks the hysteresis first but cannot find it, since
the model under it still has the wrong actuator.

So when criticism ranks an effect e first with positive evidence without finding it, and the
stage kept some components and rejected others, the rejected ones (e itself excepted) are tried
again: the stage's rounds on the model with e, from e's joint fit. The components kept now and
e are scored together against the ranking's base (criticism.candidate: explained fraction and
evidence, k = all their parameters), and e is **found** with them when that row reaches
criticism's ``min_evidence`` and ``min_fraction``. The replication check is not repeated for the
pair: the held-out flop, which neither the stage nor the fit sees, is the test.

The ranking was made on a model the stage may have left without a component, so an effect the
missing component hides can rank below a smaller one. With ``suspects`` = n > 1, each of the n
best-ranked effects with positive evidence gets its own look, and the pass takes the look that
found its effect with the most evidence (:func:`chosen`).

A size found on a second look hangs on the components that entered with it: on the Bullet testbed the
hysteresis fitted alone sat inside the truth's range, and with the actuator law beside it well
above, with a narrow interval. The data chose both the components and the size, so the
re-identified interval, conditional on that structure, is too narrow. :meth:`Revisit.check_sizes`
applies the "structure" verdict rule (belief.verdicts.RULES): a parameter of e whose value in
criticism's joint fit (e alone on the pass's model) lies outside its credible interval with the
components is *not identified*.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from belief.belief import Belief
from belief.verdicts import VERDICTS, because
from criticism.candidate import Candidate, effective_counts, scored
from criticism.mismatch import MismatchConfig, MismatchReport, superseded
from criticism.search import Criticism, CriticismConfig
from criticism.stage_journal import journalled_stage
from physics.effects import Effect, effect_from_config
from physics.trajectory_objective import TrajectoryObjective

__all__ = ["Revisit", "revisit_stage", "chosen"]


@dataclass(frozen=True)
class Revisit:
    """effect: the suspect's name; tried: the components tried again; report: the stage on the
    model with the suspect; row: the suspect with the components kept now, scored against the
    ranking's base (None when none was kept); found: whether that row passes criticism's bars;
    alone: the suspect's sizes in criticism's joint fit, without the components (name -> value)."""

    effect: str
    tried: tuple[str, ...]
    report: MismatchReport
    row: Candidate | None
    found: bool
    alone: Mapping[str, float] = field(default_factory=dict)

    @property
    def components(self) -> tuple[Effect, ...]:
        """The components kept on the second look."""
        return self.report.effects

    def text(self) -> str:
        """One line for the report."""
        head = f"second look at the stage with {self.effect}: tried {', '.join(self.tried)}"
        if self.row is None:
            return head + "; none kept"
        kept = ", ".join(e.name for e in self.components)
        verdict = "found" if self.found else "not found"
        return (f"{head}; kept {kept}; {self.effect} with {kept} explains {self.row.explained:.1%} of the held-out "
                f"error (evidence {self.row.evidence:.1f}) -> {verdict}")

    def as_dict(self) -> dict[str, Any]:
        """A JSON-able record."""
        return {"effect": self.effect, "tried": list(self.tried), "kept": [e.config() for e in self.components],
                "explained": None if self.row is None else self.row.explained,
                "evidence": None if self.row is None else self.row.evidence, "found": self.found,
                "alone": dict(self.alone)}

    def check_sizes(self, belief: Belief) -> Belief:
        """``belief`` (the re-identification with the suspect and the components) with the
        "structure" rule of the module docstring applied to the suspect's parameters: a size alone
        outside its interval makes it *not identified*."""
        intervals = belief.interval()
        kept = ", ".join(e.name for e in self.components)
        changes: dict[str, tuple[str, str]] = {}
        for name, value in self.alone.items():
            if name not in belief.space.names or belief.verdicts[name][0] == VERDICTS[2]:
                continue
            lo, hi = (float(v) for v in intervals[belief.space.index(name)])
            if not lo <= value <= hi:
                changes[name] = (VERDICTS[2], because(
                    "structure", f"{value:.4g} with {self.effect} alone but [{lo:.4g}, {hi:.4g}] with {kept} beside "
                                 f"it: the size depends on which components the same data let in"))
        return belief.overruled(changes) if changes else belief


def _suspects(crit: Criticism, stage: MismatchReport, config: MismatchConfig, n: int,
              present: Sequence[Effect] = ()) -> list[tuple[Candidate, list[Effect]]]:
    """Of the n best-ranked effects, those with positive evidence and a joint fit, each with the
    stage's rejected components worth a second look with it (module docstring), none that an effect
    ``present`` in the model replaces (Effect.replaces); [] when criticism found an effect itself."""
    if crit.found is not None or not stage.effects:
        return []
    kept = {e.name for e in stage.effects}
    out = []
    for row in [c for c in crit.ranking[:n] if c.evidence > 0 and c.theta]:
        rejected = [c for c in superseded(config.components, present) if c.name not in kept and c.name != row.name]
        if rejected:
            out.append((row, rejected))
    return out


def chosen(looks: Sequence[Revisit]) -> Revisit | None:
    """The look a pass takes: the one that found its effect with the most evidence, else the
    first (the top effect's; None without looks)."""
    found = [r for r in looks if r.found and r.row is not None]
    if found:
        return max(found, key=lambda r: r.row.evidence if r.row is not None else -np.inf)
    return looks[0] if looks else None


def revisit_stage(model: TrajectoryObjective, crit: Criticism, stage: MismatchReport, fit: np.ndarray,
                  held: np.ndarray, held_idx: Sequence[int], *, config: MismatchConfig,
                  criticism: CriticismConfig, suspects: int = 1, journal_dir: Path | None = None,
                  progress: bool = True) -> tuple[Revisit, ...]:
    """The second looks of the module docstring on ``model`` (the pass's model, at whose re-tuned
    θ̃ ``crit`` ranked), one per suspect in ranking order; fit, held: masks (S,) over its segments,
    held_idx: the held-out trajectories; journal_dir: the top suspect's stage journal (the k-th
    suspect's beside it, suffixed "-k"). () when there is no suspect or nothing to try again."""
    looks = []
    for k, (ranked, rejected) in enumerate(_suspects(crit, stage, config, suspects, model.effects)):
        journal = journal_dir if journal_dir is None or k == 0 else journal_dir.with_name(f"{journal_dir.name}-{k}")
        looks.append(_look(model, crit, ranked, rejected, fit, held, held_idx, config=config, criticism=criticism,
                           journal_dir=journal, progress=progress))
    return tuple(looks)


def _look(model: TrajectoryObjective, crit: Criticism, ranked: Candidate, rejected: list[Effect], fit: np.ndarray,
          held: np.ndarray, held_idx: Sequence[int], *, config: MismatchConfig, criticism: CriticismConfig,
          journal_dir: Path | None, progress: bool) -> Revisit:
    """One second look: the stage's rounds over ``rejected`` on the model with ``ranked``, and the
    components kept scored with it against the ranking's base."""
    effect = effect_from_config(ranked.config)
    suspect = model.with_effects(tuple(model.effects) + (effect,))
    report = journalled_stage(suspect, fit, held_idx, config=replace(config, components=tuple(rejected)),
                              journal_dir=journal_dir, progress=progress, theta=np.asarray(ranked.theta, float))
    tried = tuple(c.name for c in rejected)
    alone = {n: float(v) for n, v in ranked.values.items()}
    if not report.effects:
        return Revisit(ranked.name, tried, report, None, False, alone)
    after = suspect.with_effects(tuple(suspect.effects) + report.effects)
    stage_values = dict(zip(report.names, np.asarray(report.theta, float).tolist(), strict=True))
    theta = np.array([stage_values[n] for n in after.space.names])   # the stage orders its effects its own way
    parts = np.asarray(after.evaluate_parts(theta), float)
    n_fit, n_held = effective_counts(after.residuals(theta), fit, held)
    D = model.space.dim
    values = {n: float(v) for n, v in zip(after.space.names[D:], theta[D:], strict=True)}
    row = scored(ranked.name, "effect", values, parts, fit, held, (crit.base_fit, crit.base_held), n_fit, n_held,
                 len(values), ranked.config, ranked.placements)
    row = replace(row, stage="revisit", theta=tuple(float(v) for v in theta))
    found = row.evidence >= criticism.min_evidence and row.explained >= criticism.min_fraction
    return Revisit(ranked.name, tried, report, row, found, alone)
