"""Physics speed: wall time per simulated second, one E(θ) evaluation, and a batch on 2 workers.

Run: .venv/bin/python benchmarks/physics_speed.py [--repeats 5] [--components]
(``--components``: only the per-step cost of each mismatch-stage component against the bare model.)
Prints medians over repeats measured in this one run (the machine is shared and noisy: compare
the ratios). Targets (issue 2): <= 60 ms per simulated second at dt = 1 ms on one core; batch of 8
on 2 workers >= 1.7x faster than serial.
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from physics import FlopController, ParameterSpace, TrajectoryObjective, settled_model, simulate  # noqa: E402


def _serial_half(args) -> float:
    """Evaluate a list of θ serially in a fresh process; returns its wall time (ceiling check)."""
    objective, thetas = args
    objective(thetas[0])                      # load kernels outside the timing
    start = time.perf_counter()
    objective.evaluate_batch(thetas, parallel=False)
    return time.perf_counter() - start


def _median_time(fn, repeats: int) -> tuple[float, list[float]]:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), times


class _TimedWorld:
    """Stands in for the DART world inside ``T6Model.step`` and adds up the seconds of its ``step`` calls."""

    def __init__(self, world):
        self.world, self.seconds = world, 0.0

    def step(self):
        start = time.perf_counter()
        self.world.step()
        self.seconds += time.perf_counter() - start

    def __getattr__(self, name):
        return getattr(self.world, name)


def step_costs(repeats: int) -> dict[str, float]:
    """One simulated second of a flop (motors moving, contacts) [ms wall]: the whole step and DART's
    ``world.step`` alone, medians over ``repeats``."""
    model = settled_model()
    state = model.get_state()
    target = model.rest_length_readings().copy()
    target[:4] *= 0.8
    target[4:8] *= 1.2

    def full_second():
        model.set_state(state)
        model.step(target, n=1000)

    def engine_second() -> float:
        timed = _TimedWorld(model.world)
        model.world = timed
        try:
            full_second()
        finally:
            model.world = timed.world
        return timed.seconds

    full_second()
    whole, _ = _median_time(full_second, repeats)
    engine = float(np.median([engine_second() for _ in range(repeats)]))
    return {"ms_per_sim_second": 1e3 * whole, "engine_ms_per_sim_second": 1e3 * engine}


def objective_costs(repeats: int) -> dict[str, float]:
    """One E(θ) on a 3-s flop at 100 Hz (one-step error) [s]; a batch of 8, serial in this process
    against a local dask cluster of 2 workers [s]; and the machine's ceiling: the same 8 as two plain
    processes of 4 against one process doing all 8 (a ratio)."""
    data = simulate(controller=FlopController(heading=0.0), duration=3.0)
    E = TrajectoryObjective(data, loss="norm", n_workers=2)
    thetas = ParameterSpace.t6().sample(8, seed=0)
    E(thetas[0])
    figures = {"seconds_per_E": _median_time(lambda: E(thetas[1]), repeats)[0]}
    E.evaluate_batch(thetas[:2])          # start the cluster and warm the workers
    serial, _ = _median_time(lambda: E.evaluate_batch(thetas, parallel=False), max(1, repeats // 2))
    parallel, _ = _median_time(lambda: E.evaluate_batch(thetas), max(1, repeats // 2))
    E.close()
    from concurrent.futures import ProcessPoolExecutor
    with ProcessPoolExecutor(2) as pool:
        halves = list(pool.map(_serial_half, [(E, thetas[:4]), (E, thetas[4:])]))
    alone = _serial_half((E, thetas[:4])) + _serial_half((E, thetas[4:]))
    return {**figures, "two_process_ceiling": alone / max(halves), "batch8_serial_s": serial,
            "batch8_2workers_s": parallel, "batch8_speedup": serial / parallel}


def main(repeats: int = 5) -> dict:
    """Measure and print the figures of the module docstring; returns them."""
    figures = {**step_costs(repeats), **objective_costs(repeats)}
    print(f"cores: {os.cpu_count()}, repeats: {repeats} (medians)")
    print(f"simulated second at dt = 1 ms (flop, contacts): {figures['ms_per_sim_second']:.1f} ms wall "
          f"(target <= 60), of which DART's world.step: {figures['engine_ms_per_sim_second']:.1f} ms")
    print(f"one E(θ), 3 s of data at 100 Hz, one-step: {figures['seconds_per_E']:.3f} s")
    print(f"batch of 8 E(θ): serial {figures['batch8_serial_s']:.2f} s, 2 dask workers "
          f"{figures['batch8_2workers_s']:.2f} s, speed-up {figures['batch8_speedup']:.2f}x (target >= 1.7)")
    print(f"ceiling of this machine: two plain processes of 4 evaluations each run "
          f"{figures['two_process_ceiling']:.2f}x faster than one process doing all 8")
    return figures


def component_costs(repeats: int = 5) -> dict[str, float]:
    """Wall time per physics step [µs] of the model with each mismatch-stage component (anchors at
    6 cm), medians over ``repeats`` interleaved runs of 500 steps of a resting robot, and the ratio
    to the bare model in the same run."""
    from physics import T6Model
    from physics.effects import (
        CableAnchors,
        CylinderCaps,
        EndCapRadius,
        FixedCableAnchors,
        TensionLimitedActuation,
        model_space,
    )
    variants = {"bare T6": [], "tension_limited_actuator": [TensionLimitedActuation()],
                "cable_anchors": [CableAnchors()], "fixed_anchors": [FixedCableAnchors()],
                "end_cap_radius": [EndCapRadius()], "cylinder_caps": [CylinderCaps()]}
    models = {}
    for name, effects in variants.items():
        space = model_space(effects)
        theta = space.as_dict(None)
        theta.update({k: 0.06 for k in ("anchor_offset", "fixed_anchor_offset") if k in theta})
        models[name] = T6Model(space.as_array(theta), effects=effects)
        models[name].step(None, n=100)
    times: dict[str, list[float]] = {name: [] for name in models}
    for _ in range(repeats):
        for name, model in models.items():
            start = time.perf_counter()
            model.step(None, n=500)
            times[name].append((time.perf_counter() - start) / 500 * 1e6)
    bare = float(np.median(times["bare T6"]))
    print("per physics step, resting robot (medians, one run):")
    for name, t in times.items():
        print(f"  {name:26s} {np.median(t):6.1f} µs  {np.median(t) / bare:4.2f}x the bare T6")
    return {name: float(np.median(t)) for name, t in times.items()}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--components", action="store_true", help="only the per-step cost of the mismatch "
                        "stage's components")
    args = parser.parse_args()
    if not args.components:
        main(args.repeats)
    component_costs(args.repeats)
