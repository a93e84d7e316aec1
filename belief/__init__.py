"""What we believe about θ: grids over a latent box, the GP surrogate (pyro), log expected
improvement, the posterior P over the grid and its Belief object with verdicts (and the parameters
pinned at a bound of the box, evidence of model inadequacy), the identifiability map (what the
data pin: directions, symmetries, inert parameters), the local stage at the data's resolution,
the likelihood's scale measured from the data, noise rules for
data with model error, proposers and the identification driver (Zhu et al. 2018, Algorithm 1),
its SQLite journal, and what to record next (the flop whose data would bring the most information).

belief depends on embeddings (decoders) and physics (parameter spaces, errors); it builds no
simulator itself: it calls objectives θ -> E(θ), and for the next recording asks physics for the
objective of candidate flops (physics.candidate_recordings).
"""
from __future__ import annotations

from belief.acquisition import log_expected_improvement, log_h, select_cells
from belief.belief import Belief
from belief.bounds import AT_BOUND_TOLERANCE, AtBound, at_bounds
from belief.errors import (
    BeliefError,
    BudgetError,
    BudgetWarning,
    GridError,
    JournalError,
    ObjectiveError,
    SurrogateError,
)
from belief.grid import CandidateSet, Grid, SobolCandidates, candidates_from_config
from belief.handoff import Carried, carry_over, continue_in
from belief.identifiability import Direction, Identifiability, Symmetry, identifiability
from belief.identify import identify
from belief.journal import Journal, Record
from belief.least_squares import FitConfig, LocalStep, StepConfig, gauss_newton_fit, gauss_newton_step
from belief.local_belief import LocalConfig, NoLocalStage, local_stage
from belief.next_recording import DesignConfig, RecordingSuggestion, next_recording, suggest_recording
from belief.noise import (
    DEFAULT_DISCREPANCY,
    NOISE_RULES,
    EffectiveSize,
    effective_size,
    noise_var_from_residuals,
    segment_discrepancy,
)
from belief.posterior import (
    FLOORS,
    PosteriorConfig,
    credible_mask,
    credible_region,
    entropy,
    error_floor,
    estimate_noise_var,
    log_likelihood,
    marginals,
    posterior_from_surrogate,
)
from belief.presets import DEFAULT_PRESET, PRESETS, Preset, PresetWarning, run_preset
from belief.proposers import BOProposer, Proposal, Proposer, RandomProposer, SobolDesign
from belief.result import IdentificationResult
from belief.sampling import SamplingBelief
from belief.scale import Scale, ScaleConfig, calibrated_scale
from belief.search import problem_fingerprint, search
from belief.surrogate import GPSurrogate, SurrogateConfig
from belief.verdicts import VERDICTS, VerdictConfig

__all__ = [
    "BeliefError", "BudgetError", "GridError", "JournalError", "ObjectiveError", "SurrogateError",
    "BudgetWarning", "Belief", "SamplingBelief", "CandidateSet", "Grid", "SobolCandidates", "candidates_from_config",
    "DEFAULT_DISCREPANCY", "NOISE_RULES", "EffectiveSize", "effective_size", "noise_var_from_residuals",
    "segment_discrepancy",
    "Proposal", "Proposer", "RandomProposer", "SobolDesign", "BOProposer", "VERDICTS", "VerdictConfig",
    "GPSurrogate", "SurrogateConfig",
    "log_h", "log_expected_improvement", "select_cells",
    "FLOORS", "PosteriorConfig", "posterior_from_surrogate", "log_likelihood", "error_floor", "estimate_noise_var",
    "credible_mask", "credible_region", "entropy", "marginals",
    "Journal", "Record",
    "identify", "search", "problem_fingerprint", "DEFAULT_PRESET", "PRESETS", "Preset", "PresetWarning", "run_preset",
    "IdentificationResult", "Carried", "carry_over", "continue_in",
    "LocalStep", "StepConfig", "gauss_newton_step", "AT_BOUND_TOLERANCE", "AtBound", "at_bounds",
    "Direction", "Identifiability", "Symmetry", "identifiability",
    "FitConfig", "gauss_newton_fit", "LocalConfig", "NoLocalStage", "local_stage", "ScaleConfig", "Scale",
    "calibrated_scale", "DesignConfig", "RecordingSuggestion", "next_recording", "suggest_recording",
]
