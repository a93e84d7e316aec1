"""Model criticism: where the identified model misses the data, which physical effect it lacks,
and whether adding that effect helps on held-out data.

- :mod:`criticism.residuals`: residuals r_i = x_i - x̂_i by node, axis and time, labelled by phase
  (rest, actuating, contact);
- :mod:`criticism.search`: rank a catalog of effects (physics.effects) by the held-out error they
  explain beyond re-tuning the model's own parameters (evidence as a BIC difference), verdict
  "found" or "unexplained"; :mod:`criticism.screening` fits an effect's parameters with the model's
  held, :mod:`criticism.replication` asks a found effect to carry over between trajectories;
- :mod:`criticism.discrimination`: how far two contenders' fitted models predict apart, under the
  recorded flops and candidate ones (the flop that would tell them apart);
- :mod:`criticism.diagnose`: the loop identify -> criticize -> add the effect -> re-identify (after
  the mismatch stage and the effects the resting robot shows); :mod:`criticism.wider_box` tests the
  parameters the re-tuning leaves at a bound: box too narrow, or compensation for what the model lacks;
- :mod:`criticism.report`: the diagnosis as text, JSON and figures; :mod:`criticism.cli`: the
  ``tensegrid diagnose`` command.

criticism depends on belief (identification, posterior, least squares, noise), embeddings (the
identity decoder) and physics (the effect-aware objective contract
:class:`physics.effect_objective.EffectObjective`, the effects, the trajectory error); nothing
below it imports criticism.
"""
from __future__ import annotations

from criticism.diagnose import DiagnoseConfig, Diagnosis, Pass, diagnose, retuned_at_bounds, shown_at_rest, split_masks
from criticism.discrimination import Separation, flop_candidates, recorded_controllers, separations
from criticism.errors import CriticismError
from criticism.replication import replication_gains
from criticism.report import diagnosis_record, diagnosis_text, write_report
from criticism.residuals import PHASES, PhaseRule, phases, residual_dataset, residual_summary
from criticism.screening import fit_effect
from criticism.search import Candidate, Criticism, CriticismConfig, criticize, polish
from criticism.wider_box import BoundOutcome, WiderBoxCheck, WiderBoxConfig, check_wider_box

__all__ = [
    "CriticismError", "Separation", "flop_candidates", "recorded_controllers", "separations",
    "DiagnoseConfig", "Diagnosis", "Pass", "diagnose", "retuned_at_bounds", "shown_at_rest", "split_masks",
    "CriticismConfig", "Candidate", "Criticism", "criticize", "fit_effect", "polish", "replication_gains",
    "PHASES", "PhaseRule", "phases", "residual_dataset", "residual_summary",
    "diagnosis_text", "diagnosis_record", "write_report",
    "BoundOutcome", "WiderBoxCheck", "WiderBoxConfig", "check_wider_box",
]
