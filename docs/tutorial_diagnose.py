"""Tutorial: close the loop on data with an effect nobody told the identifier about.

The "robot" here is the simulated SUPERball with an actuator delay of 80 ms (commands reach the
motors late, as over a slow bus). Three flops toward three headings are recorded with 0.2 mm
motion-capture noise; the recordings do not say that anything is delayed. ``diagnose``

0. tries the mismatch stage's component changes (another actuator law, cable anchors, end caps,
   rolling resistance; docs/diagnose.md, "Engine mismatch"): on the engine's own data it keeps
   none (the quick mode skips it),
1. identifies the 15 T6 parameters on the first two flops,
2. ranks the catalog effects by how much of the third flop's residual each explains beyond what
   re-tuning the model's own parameters explains (the floor),
3. adds the winner, identifies again with it, and reports the third flop's error before and after.

Run::

    .venv/bin/python docs/tutorial_diagnose.py --out out/tutorial_diagnose     # a few minutes
    .venv/bin/python docs/tutorial_diagnose.py --quick --out /tmp/tut          # what the tests run

The same from the command line::

    tensegrid simulate --effect actuator_delay=0.08 --duration 1.5 --noise 0.0002 --seed 0 --heading 0 --out out/d0
    tensegrid simulate --effect actuator_delay=0.08 --duration 1.5 --noise 0.0002 --seed 1 --heading 2.1 --out out/d1
    tensegrid simulate --effect actuator_delay=0.08 --duration 1.5 --noise 0.0002 --seed 2 --heading 4.2 --out out/d2
    tensegrid diagnose out/d0/trajectory.nc out/d1/trajectory.nc out/d2/trajectory.nc --out out/diagnose
"""
from __future__ import annotations

import argparse
import os

from belief.least_squares import LeastSquaresConfig
from criticism import CriticismConfig, DiagnoseConfig, diagnose, diagnosis_text, write_report
from physics import FlopController, describe_trajectory, simulate
from physics.effects import ActuatorDelay, GroundSlope, RateLimitedActuation, SensorBias, catalog, model_space


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/tutorial_diagnose")
    ap.add_argument("--quick", action="store_true", default=os.environ.get("TENSEGRID_QUICK") == "1",
                    help="four effects, smaller budgets, one pass (what the test suite runs)")
    args = ap.parse_args()

    # The robot: nominal T6 plus an 80 ms actuator delay the identifier is not told about.
    hidden = [ActuatorDelay()]
    theta = model_space(hidden).as_array({"actuator_delay": 0.08})
    data = [simulate(theta, controller=FlopController(heading), duration=1.5, effects=hidden,
                     noise=0.0002, seed=k) for k, heading in enumerate((0.0, 2.1, 4.2))]
    print("what the first recording holds:", "; ".join(describe_trajectory(data[0])))

    # Identify on flops 0 and 1, criticize on flop 2, add what is found, identify again.
    if args.quick:   # four effects, coarser fits of one short least-squares run each, one pass, no mismatch
        config = DiagnoseConfig(budget=24, candidates=512, passes=1, mismatch=None,   # stage: the loop in minutes
                                criticism=CriticismConfig(grid=5, refine=3, joint=1,
                                                          local=LeastSquaresConfig(evaluations=6)))
        effects = [ActuatorDelay(), RateLimitedActuation(), SensorBias(), GroundSlope()]
    else:
        config, effects = DiagnoseConfig(budget=40, candidates=2048, passes=2), catalog()
    result = diagnose(data, held_out=[2], effects=effects, config=config, journal_dir=args.out,
                      n_workers=0 if args.quick else 2)
    print(diagnosis_text(result))
    for path in write_report(result, data, args.out):
        print("wrote", path)


if __name__ == "__main__":
    main()
