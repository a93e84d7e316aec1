"""Two-flop lookahead: the flops still needed after a candidate flop, with the next one predicted from geometry.

A flop tips the robot across one edge of its resting face, so the robot moves on a lattice of
faces, and a goal disc (centre g, radius r) can lie between the faces one greedy flop reaches.
One-flop progress then prefers nudges of a few centimetres (actions that rock the robot without
changing the face) to a flop that overshoots. Scoring the landing by what the *next* flop can do
sees the lattice. For a landing state with centre c₁ and the outward normals n_e of its resting
face's three edges (:func:`planners.actions.face_headings`), the next flop across edge e lands
near c₁ + L n_e, with L the median length of the flops in the rollout set that changed face::

    d(c)          = max(‖g − c‖ − r, 0)                               distance to the disc [m]
    flops_to_go   = 0                                   if d(c₁) = 0
                  = 1 + min(d(c₁), min_e d(c₁ + L n_e)) / L   otherwise     [flops]

A landing in the disc needs nothing more; one from which a flop reaches the disc needs one; else
one plus the remaining distance in flop lengths. Staying put (a nudge, a flop that failed) costs
a flop, so it is no longer free. Not "ok" outcomes count as staying at c₀.
"""
from __future__ import annotations

import numpy as np

from planners.actions import face_headings
from planners.errors import PlannerError
from planners.rollouts import RolloutSet

__all__ = ["DEFAULT_FLOP_LENGTH", "flop_length", "distance_to_disc", "flops_to_go"]

#: flop length [m] used when no rollout of the set changed face
DEFAULT_FLOP_LENGTH = 0.5


def flop_length(rs: RolloutSet) -> float:
    """Median ‖Δc‖ [m] of the rollouts that changed face, else :data:`DEFAULT_FLOP_LENGTH`."""
    flopped = rs.flopped
    if not flopped.any():
        return DEFAULT_FLOP_LENGTH
    return float(np.median(np.linalg.norm(rs.displacement[flopped], axis=-1)))


def distance_to_disc(centres: np.ndarray, goal: np.ndarray, radius: float) -> np.ndarray:
    """d(c) = max(‖g − c‖ − r, 0) [m] for centres ``... x 2``."""
    return np.maximum(np.linalg.norm(np.asarray(goal, float) - np.asarray(centres, float), axis=-1) - radius, 0.0)


def flops_to_go(rs: RolloutSet, goal: np.ndarray, radius: float) -> np.ndarray:
    """Flops still needed after each outcome (module docstring), ``n_a x K``."""
    if not (np.isfinite(radius) and radius >= 0):
        raise PlannerError(f"radius must be a distance >= 0 [m], got {radius!r}.")
    L = flop_length(rs)
    c0 = rs.start.centre
    out = np.empty(rs.ok.shape)
    for a, row in enumerate(rs.outcomes):
        for k, o in enumerate(row):
            c1 = c0 + o.displacement if o.ok else c0
            nodes = o.final.nodes if o.ok and o.final is not None else rs.start.nodes
            d1 = float(distance_to_disc(c1, goal, radius))
            if d1 == 0.0:
                out[a, k] = 0.0
                continue
            h = face_headings(nodes)
            nxt = c1[None] + L * np.column_stack([np.cos(h), np.sin(h)])
            out[a, k] = 1.0 + min(d1, float(distance_to_disc(nxt, goal, radius).min())) / L
    return out
