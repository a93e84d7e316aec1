"""Tutorial: simulate the SUPERball flopping, look at it, and measure E(θ).

Run it:  .venv/bin/python docs/tutorial_simulate.py [--quick] [--out out/tutorial]
(the test suite runs it with --quick).
"""
from __future__ import annotations

import argparse
from pathlib import Path

from physics import FlopController, ParameterSpace, TrajectoryObjective, load_trajectory, save_trajectory, simulate
from physics.plotting import plot_trajectory


def main(quick: bool = False, out: str = "out/tutorial") -> dict:
    out_dir = Path(out)
    # 1. The 15 parameters: nominal values, units and the ±10 % box.
    space = ParameterSpace.t6()
    for p in list(space)[:3]:
        print(f"{p.name:>16s} = {p.nominal:g} {p.unit}  in [{p.lower:g}, {p.upper:g}]")

    # 2. Simulate a flop toward +x at the nominal parameters (the robot first settles on a face).
    duration = 2.0 if quick else 3.0
    data = simulate(controller=FlopController(heading=0.0), duration=duration)
    com = data["nodes"].mean("node")
    print(f"centre of mass moved {float(com[-1, 0] - com[0, 0]):+.3f} m along x in {duration} s")

    # 3. Save it as netCDF (the format motion-capture data is brought in) and read it back.
    path = save_trajectory(data, out_dir / "flop.nc")
    data = load_trajectory(path)

    # 4. Draw it.
    png = plot_trajectory(data, out_dir / "flop.png", title="A flop of the nominal SUPERball")
    print(f"wrote {path} and {png}")

    # 5. The trajectory error E(θ): ~0 at the parameters that made the data, larger elsewhere.
    E = TrajectoryObjective(data, loss="norm")        # Σ‖r‖ in metres (the default is loss="squared")
    e_true = E(space.nominal)
    e_off = E(space.replace(pretension=0.95 * 150.0))
    print(f"E(θ_true) = {e_true:.4f} m, E(pretension -5 %) = {e_off:.4f} m")
    return {"e_true": e_true, "e_off": e_off, "png": png, "moved": float(com[-1, 0] - com[0, 0])}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter simulation (for the tests)")
    parser.add_argument("--out", default="out/tutorial")
    args = parser.parse_args()
    main(args.quick, args.out)
