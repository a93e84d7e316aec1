"""What diagnose returns: one :class:`Pass` per round of criticism and the whole :class:`Diagnosis`
(criticism.diagnose runs them; criticism.report and criticism.html_report present them)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from belief.belief import Belief
from belief.bounds import AtBound
from criticism.candidate import Candidate
from criticism.contact import ContactReading
from criticism.mismatch import MismatchReport
from criticism.revisit import Revisit, chosen
from criticism.search import Criticism
from criticism.wider_box import WiderBoxCheck
from physics.actuator_choice import ActuatorChoice
from physics.effects import Effect, effect_from_config

__all__ = ["Pass", "Diagnosis", "read_components"]


@dataclass
class Pass:
    """One pass: the model's effects, θ̃ (re-tuned by criticism) and its parameter names, the
    criticism, the held-out error per trajectory before, and (when an effect was added) θ̂ and the
    error after, and the Belief; at_bounds: the parameters the re-tuning left at a bound of the box
    (criticism.wider_box.retuned_at_bounds); wider_box: what re-fitting them in a wider box found
    (criticism.wider_box.check_wider_box; None when none is pinned or the test is off)."""

    effects: tuple[str, ...]
    names: tuple[str, ...]
    theta: np.ndarray
    criticism: Criticism
    held_before: dict[str, float]
    added: str | None = None
    names_after: tuple[str, ...] = ()
    theta_after: np.ndarray | None = None
    held_after: dict[str, float] | None = None
    belief_after: Belief | None = None
    at_bounds: tuple[AtBound, ...] = ()
    looks: tuple[Revisit, ...] = ()
    wider_box: WiderBoxCheck | None = None

    @property
    def revisit(self) -> Revisit | None:
        """The second look the pass takes (criticism.revisit.chosen); None without looks."""
        return chosen(self.looks)

    @property
    def second_look(self) -> Revisit | None:
        """The second look (criticism.revisit) when it found this pass's effect; None when
        criticism found it itself or nothing was found."""
        found_here = self.criticism.found is None and self.revisit is not None and self.revisit.found
        return self.revisit if found_here else None

    @property
    def found(self) -> Candidate | None:
        """The row of the effect this pass found: criticism's, or the second look's (criticism.revisit)."""
        if self.criticism.found is not None:
            return self.criticism.found
        return self.second_look.row if self.second_look is not None else None

    @property
    def additions(self) -> tuple[Effect, ...]:
        """The effects this pass adds to the model: the found one, then the components the second
        look let in with it; () when nothing was found."""
        row = self.found
        if row is None:
            return ()
        extra = self.second_look.components if self.second_look is not None else ()
        return (effect_from_config(row.config),) + extra

    def estimates(self) -> dict[str, dict[str, Any]]:
        """The added effect's parameters after re-identification: name -> {"value" (best θ),
        "lower", "upper" (the Belief's credible interval), "level", "verdict", "reason", "at_bound"
        ("lower" or "upper" when pinned there, else "")}; empty when nothing was added."""
        if self.theta_after is None:
            return {}
        names = self.names_after[len(self.names):]
        after = dict(zip(self.names_after, self.theta_after.tolist(), strict=True))
        out: dict[str, dict[str, Any]] = {n: {"value": after[n]} for n in names}
        if self.belief_after is not None:
            m = self.belief_after.marginals()
            for n in names:
                row = m.sel(parameter=n)
                out[n].update(lower=float(row["lower"]), upper=float(row["upper"]), level=float(m.attrs["level"]),
                              verdict=str(row["verdict"].values), reason=str(row["reason"].values),
                              at_bound=str(row["at_bound"].values))
        return out

    @property
    def reduction(self) -> float | None:
        """1 - E_after / E_before on all held-out data, or None when nothing was added."""
        if self.held_after is None:
            return None
        return 1.0 - sum(self.held_after.values()) / sum(self.held_before.values())


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`: the passes, the final effects, the held-out trajectories
    (indices; empty with one trajectory: then errors are in-sample), the first identification's
    Belief (None if it made none), the objective's settings, the mismatch stage's report, the
    effects measured at rest (:func:`shown_at_rest`, bound to the data) and the contact read from
    the flops (criticism.contact; None when not read), the actuator read from the encoders
    (physics.actuator_choice; None when not read)."""

    passes: list[Pass]
    effects: tuple[str, ...]
    held_out: list[int]
    belief: Belief | None
    settings: dict[str, Any]
    mismatch: MismatchReport | None = None
    measured: tuple[Effect, ...] = ()
    contact: ContactReading | None = None
    actuator: ActuatorChoice | None = None

    @property
    def found(self) -> list[str]:
        """The effects added, in order: those measured at rest, then those criticism found."""
        return [e.name for e in self.measured] + [p.added for p in self.passes if p.added is not None]

    @property
    def first_model(self) -> tuple[Effect, ...]:
        """The effects of the model of pass 1: the actuator read from the encoders, the components the
        contact reading put in, the mismatch stage's, then those measured at rest."""
        read = read_components(self.actuator, self.contact)
        return read + (self.mismatch.effects if self.mismatch is not None else ()) + self.measured


def read_components(actuator: ActuatorChoice | None, contact: ContactReading | None) -> tuple[Effect, ...]:
    """The effects read from the data before any identification: the measured actuator, when it is
    the model's (physics.actuator_choice), then the contact reading's components."""
    measured = (actuator.effect,) if actuator is not None and actuator.effect is not None else ()
    return measured + (contact.components if contact is not None else ())
