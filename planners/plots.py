"""Figures of plans and probes (matplotlib, Agg backend: no display needed).

- :func:`plot_plan`: left, the ground plane: the goal and its radius, the resting faces (triangles
  of the three lowest nodes) along the robot's path, the centre's path of each planner compared,
  and for every step the centres the chosen flop reached under the K draws of P (the spread of
  outcomes); right, the value of every candidate of the first step under each draw of P (progress
  [m] with horizon 1, −flops to go with horizon 2), the chosen one marked, with the mean and the CVaR;
- :func:`plot_probe`: entropy of P over the probed cells and the chosen action's expected gain
  per probe.
"""
from __future__ import annotations

import os
from collections.abc import Mapping

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from planners.probe import ProbeRun  # noqa: E402
from planners.robust import GoalRun, cvar  # noqa: E402

__all__ = ["plot_plan", "plot_probe"]


def _face(ax: plt.Axes, nodes: np.ndarray, color: str) -> None:
    tri = nodes[np.argsort(nodes[:, 2])[:3], :2]
    ax.fill(tri[:, 0], tri[:, 1], facecolor=color, edgecolor=color, alpha=0.18, lw=0.8)


def _ground(ax: plt.Axes, run: GoalRun, others: Mapping[str, GoalRun]) -> None:
    ax.add_patch(plt.Circle(tuple(run.goal), run.radius, color="C2", alpha=0.15))
    ax.plot(*run.goal, "*", color="C2", ms=14, label="goal")
    for step in run.steps:
        rs = step.choice.rollouts
        _face(ax, np.asarray(rs.start.nodes), "0.3")
        row = rs.outcomes[step.choice.index]
        for o in row:
            if o.ok:
                ax.plot(*o.path.T, color="C0", alpha=0.12, lw=0.7)
        ends = np.array([rs.start.centre + o.displacement for o in row if o.ok]).reshape(-1, 2)
        ax.plot(ends[:, 0], ends[:, 1], ".", color="C0", alpha=0.5, ms=5)
    if run.steps and run.steps[-1].outcome.final is not None:
        _face(ax, np.asarray(run.steps[-1].outcome.final.nodes), "0.3")
    ax.plot(*run.path.T, "o-", color="C3", lw=2, ms=4, label="robust plan, robot (θ*)")
    for k, (name, other) in enumerate(others.items()):
        ax.plot(*other.path.T, "s--", color=f"C{4 + k}", lw=1.4, ms=3, label=f"{name} plan, robot (θ*)")
    ax.plot([], [], ".", color="C0", label="predicted ends under P")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=7, loc="best")
    ax.set_title(f"{len(run.steps)} flops, {'reached' if run.reached else 'not reached'} "
                 f"(final distance {run.final_distance:.2f} m)", fontsize=9)


def _spread(ax: plt.Axes, run: GoalRun) -> None:
    choice = run.steps[0].choice
    prog = choice.progress if choice.values is None else choice.values
    for a in range(prog.shape[0]):
        x = np.full(prog.shape[1], a) + np.linspace(-0.2, 0.2, prog.shape[1])
        ax.plot(x, prog[a], ".", color="C3" if a == choice.index else "0.5", ms=4)
        ax.plot([a - 0.3, a + 0.3], [prog[a].mean()] * 2, "-", color="k", lw=1)
        ax.plot([a - 0.3, a + 0.3], [cvar(prog[a], choice.level)] * 2, "-", color="C1", lw=1.5)
    ax.plot([], [], "-", color="k", label="mean")
    ax.plot([], [], "-", color="C1", label=f"CVaR α={choice.level:g}")
    ax.set_xticks(range(prog.shape[0]))
    ax.set_xticklabels([a.label for a in choice.rollouts.actions], rotation=70, fontsize=6)
    ax.set_ylabel("progress toward the goal [m]" if choice.horizon == 1 else "−flops to go (two-flop lookahead)")
    ax.set_title(f"first step: {prog.shape[1]} draws of P per candidate ({choice.risk})", fontsize=9)
    ax.legend(fontsize=7)


def plot_plan(run: GoalRun, path: str | os.PathLike[str], *, others: Mapping[str, GoalRun] | None = None) -> None:
    """Write the plan figure (module docstring) of ``run``, with ``others`` (name -> run) compared."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.2), gridspec_kw={"width_ratios": [1.2, 1]})
    _ground(axes[0], run, dict(others or {}))
    if run.steps:
        _spread(axes[1], run)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_probe(run: ProbeRun, path: str | os.PathLike[str]) -> None:
    """Entropy of the probed P [nats] before/after each probe and the chosen action's expected gain."""
    fig, ax = plt.subplots(figsize=(6, 4))
    if run.steps:
        h = [run.steps[0].entropy_before] + [s.entropy_after for s in run.steps]
        ax.plot(range(len(h)), h, "o-", color="C0", label="entropy of P on the probed cells")
        ax.bar(np.arange(1, len(h)) - 0.5, [s.gain for s in run.steps], width=0.35, color="C1", alpha=0.6,
               label="expected gain of the chosen probe")
        for k, s in enumerate(run.steps, start=1):
            ax.annotate(s.action.label, (k, h[k]), fontsize=6, rotation=20)
        ax.set_xticks(range(len(h)))
    ax.set_xlabel("probes")
    ax.set_ylabel("nats")
    ax.set_title(f"probing ({run.stopped})", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
