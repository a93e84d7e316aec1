"""Two-flop lookahead: the flops still needed after a candidate flop, with the next one simulated.

A flop tips the robot across one edge of its resting face, so the robot moves on a lattice of
faces, and a goal disc (centre g, radius r) can lie between the faces one greedy flop reaches.
One-flop progress then prefers nudges of a few centimetres (actions that rock the robot without
changing the face) to a flop that overshoots. Scoring the landing by what the *next* flop can do
sees the lattice. For every resting face f that the candidates land on (and the start's face, for
outcomes that stay), :func:`next_flops` simulates the flops across f's three edges from one landing
on f, under one θ (the mean of the draws), and keeps their displacements Δ₂(f, e). An outcome with
centre c₁ on face f then has the next landings c₂ = c₁ + Δ₂(f, e)::

    d(c)          = max(‖g − c‖ − r, 0)                               distance to the disc [m]
    flops_to_go   = 0                                   if d(c₁) = 0
                  = 1 + min(d(c₁), min_e d(c₂,e)) / L + ε min_e ‖g − c₂,e‖ / L   otherwise   [flops]

with L the median length of the flops in the rollout set that changed face and ε = 0.01 (among
second flops that all reach the disc, the one that lands deepest wins). A landing in the disc
needs nothing more; one from which a flop reaches the disc needs one; else one plus the remaining
distance in flop lengths. Staying put (a nudge, a failed flop) costs a flop, so it is not
free. Without simulated next flops (``nxt`` None) Δ₂(f, e) = L n_e, n_e the outward normal of
edge e (:func:`planners.actions.face_headings`). Not "ok" outcomes count as staying at c₀.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from physics.pool import DaskPool
from planners.actions import candidate_actions, face_headings
from planners.errors import PlannerError
from planners.rollouts import RobotStart, RolloutSet, rollouts

__all__ = ["DEFAULT_FLOP_LENGTH", "TIE_BREAK", "flop_length", "distance_to_disc", "landings", "next_flops",
           "flops_to_go"]

#: weight ε of the distance after the second flop (module docstring)
TIE_BREAK = 0.01

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


def landings(rs: RolloutSet) -> dict[tuple[int, ...], RobotStart]:
    """One landing state per resting face the outcomes end on (the start's face for outcomes that stay)."""
    out: dict[tuple[int, ...], RobotStart] = {tuple(rs.start.face): rs.start}
    for row in rs.outcomes:
        for o in row:
            if o.ok and o.final is not None and tuple(o.face) not in out:
                out[tuple(o.face)] = o.final
    return out


def next_flops(rs: RolloutSet, pool: DaskPool, *, theta: np.ndarray | None = None, change: float = 0.3,
               n_cables: int = 4) -> dict[tuple[int, ...], np.ndarray]:
    """face -> Δ₂ (3 x 2) [m]: the flops across its three edges from one landing on it, simulated under
    ``theta`` (default: the mean of the set's draws); a diverged flop's row is NaN."""
    th = np.mean(rs.thetas, axis=0) if theta is None else np.asarray(theta, dtype=float)
    out = {}
    for face, start in landings(rs).items():
        acts = candidate_actions(nodes=np.asarray(start.nodes), changes=(change,), n_cables=(n_cables,))
        sub = rollouts(acts, start, th[None], pool=pool)
        out[face] = np.array([row[0].displacement for row in sub.outcomes], dtype=float).reshape(-1, 2)
    return out


def _second(o_face: tuple[int, ...], nodes: np.ndarray, L: float,
            nxt: Mapping[tuple[int, ...], np.ndarray] | None) -> np.ndarray:
    """Δ₂ (m x 2) of the face: simulated when known, else L n_e."""
    if nxt is not None and o_face in nxt:
        d = np.asarray(nxt[o_face], dtype=float)
        d = d[np.all(np.isfinite(d), axis=1)]
        if len(d):
            return d
    h = face_headings(nodes)
    return L * np.column_stack([np.cos(h), np.sin(h)])


def flops_to_go(rs: RolloutSet, goal: np.ndarray, radius: float,
                nxt: Mapping[tuple[int, ...], np.ndarray] | None = None) -> np.ndarray:
    """Flops still needed after each outcome (module docstring), ``n_a x K``; ``nxt``: :func:`next_flops`."""
    if not (np.isfinite(radius) and radius >= 0):
        raise PlannerError(f"radius must be a distance >= 0 [m], got {radius!r}.")
    L = flop_length(rs)
    c0, g = rs.start.centre, np.asarray(goal, dtype=float)
    out = np.empty(rs.ok.shape)
    for a, row in enumerate(rs.outcomes):
        for k, o in enumerate(row):
            c1 = c0 if not o.ok else c0 + o.displacement
            d1 = float(distance_to_disc(c1, g, radius))
            if d1 == 0.0:
                out[a, k] = 0.0
                continue
            final = o.final if o.ok else None           # None: the robot stays on its start face
            face, nodes = (tuple(rs.start.face), rs.start.nodes) if final is None else (tuple(o.face), final.nodes)
            c2 = c1[None] + _second(face, np.asarray(nodes), L, nxt)
            far = float(np.linalg.norm(g - c2, axis=1).min())
            out[a, k] = 1.0 + min(d1, float(distance_to_disc(c2, g, radius).min())) / L + TIE_BREAK * far / L
    return out
