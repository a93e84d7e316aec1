"""The testbed's own flop controller: tip the robot over an edge of the face it rests on.

At the start of a flop it looks at the node positions: the three nodes nearest the ground are the
base triangle; of its three edges it takes the one whose outward normal (in the ground plane) is
closest to the goal heading. It then tries each cable alone, shortened by ``change`` for
``trial`` seconds from the present state of the robot itself (Bullet's save/restore), and keeps
the ``n_cables`` whose shortening moves the centre of mass furthest across that edge; it does the
same for lengthening (other cables). Between ``start`` and ``stop`` seconds those targets are
held at (1 ∓ change) times their values at the flop's start, then all return to them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.cable_robot import CableRobot

__all__ = ["Flop", "FlopPlanner"]


@dataclass(frozen=True)
class Flop:
    """One flop: goal ``heading`` [rad from +x], relative change, cables per side, timing [s]."""

    heading: float = 0.0
    change: float = 0.3
    n_cables: int = 4
    start: float = 0.2
    stop: float = 1.2
    trial: float = 0.4

    def __post_init__(self) -> None:
        if not (0.0 < self.change < 0.5 and 1 <= self.n_cables <= 12 and 0 <= self.start < self.stop):
            raise ValueError(f"invalid flop {self!r}: need 0 < change < 0.5, 1 <= n_cables <= 12, start < stop.")


def _edge_direction(nodes: np.ndarray, normal: np.ndarray, heading: float) -> np.ndarray:
    """Unit outward normal (3,) of the base-triangle edge that faces ``heading`` most, in the plane
    with normal ``normal``."""
    base = np.argsort(nodes @ normal)[:3]
    tri = nodes[base]
    centre = tri.mean(axis=0)
    goal = np.array([np.cos(heading), np.sin(heading), 0.0])
    goal -= (goal @ normal) * normal
    best, out = -np.inf, goal
    for k in range(3):
        a, b = tri[k], tri[(k + 1) % 3]
        edge = np.cross(b - a, normal)
        edge /= np.linalg.norm(edge)
        if edge @ (0.5 * (a + b) - centre) < 0:
            edge = -edge
        if edge @ goal > best:
            best, out = edge @ goal, edge
    return out


class FlopPlanner:
    """Chooses the cables of a :class:`Flop` by trial on the robot and gives its true targets."""

    def __init__(self, flop: Flop) -> None:
        self.flop = flop
        self.shorten: tuple[int, ...] = ()
        self.lengthen: tuple[int, ...] = ()

    def plan(self, robot: CableRobot) -> None:
        """Pick the cables from the robot's present state (the robot is left as it was)."""
        f = self.flop
        self.hold = robot.rest.copy()
        direction = _edge_direction(robot.nodes(), robot.effects.ground_normal(), f.heading)
        snap = robot.snapshot()
        steps = int(round(f.trial / robot.dt))

        def effect(j: int, factor: float) -> float:
            robot.restore(snap)
            target = self.hold.copy()
            target[j] *= factor
            before = robot.com()
            for _ in range(steps):
                robot.step(target)
            return float((robot.com() - before) @ direction)

        short = np.array([effect(j, 1 - f.change) for j in range(24)])
        longer = np.array([effect(j, 1 + f.change) for j in range(24)])
        robot.restore(snap)
        robot.forget(snap)
        self.shorten = tuple(int(j) for j in np.argsort(-short)[:f.n_cables])
        self.lengthen = tuple([int(j) for j in np.argsort(-longer) if j not in self.shorten][:f.n_cables])

    def targets(self, t: float) -> np.ndarray:
        """True target rest lengths (24,) [m] at ``t`` seconds after the flop's start."""
        target = self.hold.copy()
        if self.flop.start <= t < self.flop.stop:
            target[list(self.shorten)] *= 1 - self.flop.change
            target[list(self.lengthen)] *= 1 + self.flop.change
        return target
