"""How strongly each of the 15 parameters acts: +5 % alone, on a 3-s flop at nominal θ.

Run: .venv/bin/python benchmarks/parameter_effects.py
Prints a markdown table (docs/physics.md quotes it): the largest change of any node position in
a closed-loop flop, and the growth of the one-step and rollout errors E on the nominal data.
"""
from __future__ import annotations

import numpy as np

from physics import FlopController, ParameterSpace, StateEstimator, TrajectoryObjective, simulate


def main() -> list[tuple[str, float, float, float]]:
    space = ParameterSpace.t6()
    base = simulate(controller=FlopController(heading=0.0), duration=3.0)
    one_step = TrajectoryObjective(base, loss="norm")          # metres, the paper's Σ‖r‖, as quoted in docs/physics.md
    rollout = TrajectoryObjective(base, horizon="rollout", loss="norm")
    e1, er = one_step(space.nominal), rollout(space.nominal)
    no_velocities = TrajectoryObjective(base.drop_vars("velocities"), loss="norm")
    backward = TrajectoryObjective(base.drop_vars("velocities"), loss="norm", states=StateEstimator(method="backward"))
    n1 = int(np.isfinite(one_step.per_sample(space.nominal)[0]).sum())
    n2 = int(np.isfinite(no_velocities.per_sample(space.nominal)[0]).sum())
    n3 = int(np.isfinite(backward.per_sample(space.nominal)[0]).sum())
    print(f"E(θ*) on its own noise-free data: one-step {e1:.4f} m over {n1} predictions, rollout {er:.4f} m; "
          f"with states estimated from positions: one-step {no_velocities(space.nominal):.4f} m over {n2} "
          f"(local polynomial, the default), {backward(space.nominal):.4f} m over {n3} (backward difference)")
    print("| parameter | max node change, flop [m] | ΔE one-step [m] | ΔE rollout [m] |")
    print("|---|---|---|---|")
    rows = []
    for name in space.names:
        theta = space.replace(**{name: space[name].nominal * 1.05})
        ds = simulate(theta, controller=FlopController(heading=0.0), duration=3.0)
        moved = float(np.sqrt(((ds.nodes - base.nodes) ** 2).sum("axis")).max())
        d1, dr = one_step(theta) - e1, rollout(theta) - er
        rows.append((name, moved, d1, dr))
        print(f"| {name} | {moved:.2e} | {d1:+.2e} | {dr:+.2e} |")
    return rows


if __name__ == "__main__":
    main()
