"""A row of criticism's ranking and its scores against the base model (criticism.search, steps 2-3).

For an effect e with fit and held-out errors E_F,e and E_H,e, against the base's E_F and E_H:

    explained_e = 1 - E_H,e / E_H
    evidence_e  = K_F ln(E_F / E_F,e) + K_H ln(E_H / E_H,e) - k_e ln(K_F + K_H) - 2 ln m_e

with K_F, K_H the effective residual counts (belief.noise.effective_size), k_e the effect's
parameter count and m_e the number of places it was chosen among (Effect.placements; 1 for most).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from belief.noise import effective_size

__all__ = ["Candidate", "scored", "rescore", "effective_counts", "values_text", "place_text"]


@dataclass(frozen=True)
class Candidate:
    """One row of the ranking: an effect (kind "effect") or a re-fit parameter of the model (kind
    "floor"), its fitted values, fit and held-out errors, explained fraction and evidence."""

    name: str
    kind: str
    values: dict[str, float]
    fit_error: float
    held_error: float
    explained: float
    evidence: float
    config: dict[str, Any] = field(default_factory=dict)     # Effect.config() of the effect; {} for the floor
    n_fit: float = math.nan       # K_F of its residuals
    n_held: float = math.nan      # K_H of its residuals
    stage: str = "screened"       # "screened": η fitted with θ̃ held; "joint": θ and η re-tuned together
    theta: tuple[float, ...] = ()  # the full parameter vector of the model with the effect
    placements: int = 1           # m: the effect's place was chosen among m (Effect.placements)


def values_text(values: dict[str, float]) -> str:
    """Fitted values as "name=value, ..." (4 significant digits)."""
    return ", ".join(f"{k}={v:.4g}" for k, v in values.items())


def place_text(c: Candidate) -> str:
    """Where a placed effect sits (its options), e.g. " (rod=5, position=-0.6; best of 12 places)"."""
    if c.placements == 1:
        return ""
    options = ", ".join(f"{k}={v}" for k, v in c.config.items() if k != "effect")
    return f" ({options}; best of {c.placements} places)"


def scored(name: str, kind: str, values: dict[str, float], parts: np.ndarray, fit: np.ndarray, held: np.ndarray,
               base: tuple[float, float], n_fit: float, n_held: float, k: int, config: dict[str, Any],
               placements: int = 1) -> Candidate:
    """A ranked row: explained fraction on H and evidence on F and H against ``base`` = (E_F, E_H)."""
    row = Candidate(name, kind, values, float(parts[fit].sum()), float(parts[held].sum()), -math.inf, -math.inf,
                    config, n_fit, n_held, placements=placements)
    return rescore(row, base, k)


def rescore(c: Candidate, base: tuple[float, float], k: int | None = None) -> Candidate:
    """``c`` with explained fraction and evidence (module docstring) against ``base`` = (E_F, E_H)."""
    k = len(c.values) if k is None else k
    if not (np.isfinite(c.held_error) and c.held_error > 0 and np.isfinite(c.fit_error) and c.fit_error > 0
            and np.isfinite(c.n_fit) and np.isfinite(c.n_held)):
        return replace(c, explained=-math.inf, evidence=-math.inf)
    explained = 1.0 - c.held_error / base[1]
    evidence = (c.n_fit * math.log(base[0] / c.fit_error) + c.n_held * math.log(base[1] / c.held_error)
                - k * math.log(max(c.n_fit + c.n_held, 2.0)) - 2.0 * math.log(c.placements))
    return replace(c, explained=explained, evidence=evidence)


def effective_counts(residuals: Sequence[np.ndarray], fit: np.ndarray, held: np.ndarray) -> tuple[float, float]:
    """Effective residual counts (K_F, K_H) of the residuals (S arrays) on the fit and held-out segments."""
    return (effective_size([r for r, f in zip(residuals, fit, strict=True) if f]).n_eff,
            effective_size([r for r, h in zip(residuals, held, strict=True) if h]).n_eff)
