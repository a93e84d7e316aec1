"""What we believe about θ: grids over a latent box, the GP surrogate (pyro), log expected
improvement, the posterior P over the grid, the identification loop (Zhu et al. 2018,
Algorithm 1) and its SQLite journal.

belief depends on embeddings (decoders) and physics (parameter spaces, errors); it never builds a
simulator, it only calls an objective θ -> E(θ).
"""
from __future__ import annotations

from belief.acquisition import log_expected_improvement, log_h, select_cells
from belief.errors import (
    BeliefError,
    BudgetError,
    GridError,
    JournalError,
    ObjectiveError,
    SurrogateError,
)
from belief.grid import Grid, SobolCandidates
from belief.identify import identify, problem_fingerprint
from belief.journal import Journal, Record
from belief.posterior import (
    PosteriorConfig,
    credible_mask,
    credible_region,
    entropy,
    estimate_noise_var,
    log_likelihood,
    marginals,
    posterior_from_surrogate,
)
from belief.result import IdentificationResult
from belief.surrogate import GPSurrogate, SurrogateConfig

__all__ = [
    "BeliefError", "BudgetError", "GridError", "JournalError", "ObjectiveError", "SurrogateError",
    "Grid", "SobolCandidates",
    "GPSurrogate", "SurrogateConfig",
    "log_h", "log_expected_improvement", "select_cells",
    "PosteriorConfig", "posterior_from_surrogate", "log_likelihood", "estimate_noise_var",
    "credible_mask", "credible_region", "entropy", "marginals",
    "Journal", "Record",
    "identify", "problem_fingerprint", "IdentificationResult",
]
