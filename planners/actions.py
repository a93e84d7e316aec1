"""Flop actions: what a planner may ask the robot to do, and the candidate sets it chooses from.

A :class:`FlopAction` is one flop of :class:`physics.controllers.FlopController`: toward a heading
[rad from +x], with a relative rest-length change (``change`` = 0.2 shortens ``n_cables`` cables by
20 % and lengthens as many by 20 %), held from ``start`` to ``stop`` [s], observed for ``duration``
[s] in all. The controller snaps a heading onto one of the three edges of the resting face (it
tips the robot across the edge whose outward normal points most toward the heading), so headings
120° apart, or any two headings that pick the same edge, make the same motion. Distinct motions
come from the edge *and* the actuation (change, number of cables, timing); :func:`face_headings`
gives the three edge normals of a resting state, and :func:`candidate_actions` crosses headings
with actuations.
"""
from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from physics.controllers import FlopController
from physics.controllers import face_headings as physics_face_headings
from physics.errors import ControllerError
from physics.geometry import N_CABLES
from planners.errors import ActionError

__all__ = ["FlopAction", "face_headings", "candidate_actions", "DEFAULT_CHANGES", "DEFAULT_N_CABLES"]

#: rest-length changes of the default candidate set (relative)
DEFAULT_CHANGES: tuple[float, ...] = (0.18, 0.3)
#: numbers of shortened (and lengthened) cables of the default candidate set
DEFAULT_N_CABLES: tuple[int, ...] = (3, 4)


def _number(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ActionError(f"{name} must be a number, got {value!r}.")
    if not math.isfinite(float(value)):
        raise ActionError(f"{name} must be finite, got {value!r}.")
    return float(value)


@dataclass(frozen=True)
class FlopAction:
    """One flop: heading [rad], change (relative, in (0, 0.5)), n_cables (1..12 shortened and as many
    lengthened), start < stop [s] the interval the change is held, duration [s] >= stop observed
    in all (the robot settles after ``stop``). Raises :class:`ActionError` when invalid."""

    heading: float
    change: float = 0.2
    n_cables: int = 4
    start: float = 0.2
    stop: float = 1.2
    duration: float = 2.0

    def __post_init__(self) -> None:
        for name in ("heading", "change", "start", "stop", "duration"):
            object.__setattr__(self, name, _number(getattr(self, name), name))
        if not 0.0 < self.change < 0.5:
            raise ActionError("change must be a relative rest-length change in (0, 0.5), e.g. 0.2, got "
                              f"{self.change!r}.")
        if isinstance(self.n_cables, bool) or not isinstance(self.n_cables, (int, np.integer)) or \
                not 1 <= int(self.n_cables) <= N_CABLES // 2:
            raise ActionError(f"n_cables must be an integer in 1..{N_CABLES // 2}, got {self.n_cables!r}.")
        object.__setattr__(self, "n_cables", int(self.n_cables))
        if not 0.0 <= self.start < self.stop <= self.duration <= 10.0:
            raise ActionError(f"need 0 <= start < stop <= duration <= 10 s, got start={self.start}, stop={self.stop}, "
                              f"duration={self.duration}; lengthen duration or move stop earlier.")
        object.__setattr__(self, "heading", float(np.mod(self.heading, 2 * np.pi)))

    def controller(self) -> FlopController:
        """The :class:`~physics.controllers.FlopController` making this flop (one flop, period = duration)."""
        return FlopController(self.heading, change=self.change, n_cables=self.n_cables, start=self.start,
                              stop=self.stop, period=self.duration, flops=1)

    @property
    def label(self) -> str:
        """Short text, e.g. ``"h=30° c=0.20 n=4"``."""
        return f"h={np.degrees(self.heading):.0f}° c={self.change:.2f} n={self.n_cables}"

    def as_dict(self) -> dict[str, float]:
        """JSON-able fields."""
        return {"heading": self.heading, "change": self.change, "n_cables": self.n_cables, "start": self.start,
                "stop": self.stop, "duration": self.duration}


def face_headings(nodes: np.ndarray) -> np.ndarray:
    """Headings [rad in [0, 2π)] of the outward normals of the resting face's three edges, shape ``3``
    (:func:`physics.controllers.face_headings`); raises :class:`ActionError` for nodes that are not
    12 x 3 finite positions [m]."""
    try:
        return physics_face_headings(nodes)
    except ControllerError as exc:
        raise ActionError(str(exc)) from None


def _headings(headings: int | Sequence[float] | np.ndarray | None, nodes: np.ndarray | None) -> np.ndarray:
    if headings is None:
        if nodes is None:
            raise ActionError("candidate_actions needs headings (an int or a list of radians) or nodes (12 x 3) of "
                              "the resting state to take the three edge normals from.")
        return face_headings(nodes)
    if isinstance(headings, bool):
        raise ActionError(f"headings must be an int count or a list of radians, got {headings!r}.")
    if isinstance(headings, (int, np.integer)):
        if headings < 1:
            raise ActionError(f"headings must be >= 1 evenly spaced directions, got {headings!r}.")
        return 2 * np.pi * np.arange(int(headings)) / int(headings)
    out = np.array([_number(h, "heading") for h in headings], dtype=float)
    if out.size == 0:
        raise ActionError("headings is empty; give at least one heading [rad] or an int count.")
    return out


def candidate_actions(headings: int | Sequence[float] | np.ndarray | None = None, *,
                      nodes: np.ndarray | None = None, changes: Sequence[float] = DEFAULT_CHANGES,
                      n_cables: Sequence[int] = DEFAULT_N_CABLES, start: float = 0.2, stop: float = 1.2,
                      duration: float = 2.0) -> tuple[FlopAction, ...]:
    """Candidate flops: headings x changes x n_cables (in that nesting order), duplicates removed.

    ``headings``: an int n (n evenly spaced headings 2πk/n), a sequence [rad], or None for the three
    edge normals of the resting face of ``nodes`` (12 x 3 [m], :func:`face_headings`: the distinct
    flops of the controller). Raises :class:`ActionError` for an empty set or invalid values.
    """
    hs = _headings(headings, nodes)
    changes, n_cables = list(changes), list(n_cables)
    if not changes or not n_cables:
        raise ActionError(f"changes and n_cables must be non-empty, got changes={changes}, n_cables={n_cables}.")
    out: list[FlopAction] = []
    for h, c, n in itertools.product(hs, changes, n_cables):
        action = FlopAction(float(h), c, n, start, stop, duration)
        if action not in out:
            out.append(action)
    return tuple(out)
