"""What a flop can pin down: the mass-scale symmetry and the weak directions of the 12 parameters
the T6 shares with the foreign testbed robot.

For the bare T6 (its DART motors) and for the model the mismatch stage keeps on testbed data
(physics.effects: tension-limited actuator, cable anchors at 6 cm, rolling resistance 0.5 m), on
a 3-s flop (FlopController, heading 0) at nominal θ, noise-free, this script prints

1. the symmetry (physics.scaling): the node change [mm, RMS and max] when every mass and force is
   multiplied by ``--lam``, (a) with the model's default options, whose constants of mass dimension
   (the rods' spin damping, the motor driver's speed gain K_v) follow the robot's mass: the symmetry
   is exact, this must be 0; (b) with those constants held at their absolute values at θ
   (``scale_options(options, 1 / λ)``), what such constants would tell the data of the scale; next
   to each shared parameter alone +2 %;
2. the local sensitivities: J = ∂nodes/∂log θ_j (central differences, ±1 %) over the 12 shared
   parameters, its singular values s_i as the RMS node change [mm] of a 2 % step along each
   singular direction (0.02 s_i / √N, N the number of node coordinates), and the loadings of the
   weakest directions. A direction whose 2 % step moves the nodes less than the marker noise
   (0.2 mm) or far less than the engine mismatch (tens of mm, benchmarks/mismatch.py) cannot be
   pinned to 2 % by such data; any parameter loading on it can land anywhere along it. The mass
   scale is one of these directions, with a singular value of 0 to rounding.

    .venv/bin/python benchmarks/identifiability.py
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
from tqdm import tqdm

from physics import FlopController, ModelOptions, simulate
from physics.effects import CableAnchors, Effect, RollingResistance, TensionLimitedActuation, model_space
from physics.scaling import scale_masses, scale_options

INERT = ("motor_radius", "motor_friction", "motor_inertia")
MODELS: dict[str, tuple[tuple[Effect, ...], dict[str, float]]] = {
    "T6 (DART motors)": ((), {}),
    "stage's model": ((TensionLimitedActuation(), CableAnchors(), RollingResistance()),
                      {"anchor_offset": 0.06, "rolling_resistance": 0.5}),
}


def _flop(effects: tuple[Effect, ...], theta: np.ndarray, options: ModelOptions | None = None) -> np.ndarray:
    """Node positions (T x 12 x 3) [m] of the 3-s flop at θ."""
    ds = simulate(theta, controller=FlopController(heading=0.0), duration=3.0, effects=effects,
                  space=model_space(effects), options=options or ModelOptions())
    return ds.nodes.values


def _mm(a: np.ndarray, b: np.ndarray) -> str:
    d = np.linalg.norm(a - b, axis=-1)
    return f"RMS {1e3 * np.sqrt(np.mean(d**2)):8.4f} mm, max {1e3 * d.max():8.4f} mm"


def symmetry(effects: tuple[Effect, ...], theta: np.ndarray, base: np.ndarray, lam: float) -> None:
    """Part 1: the node change of the scaled θ, with the model's constants following the mass (its
    default: exact) and with them held at their absolute values at θ."""
    space = model_space(effects)
    scaled = scale_masses(space, theta, lam)
    held = _flop(effects, scaled, scale_options(ModelOptions(), 1.0 / lam))
    print(f"  every mass and force x {lam:g}, exact symmetry: {_mm(_flop(effects, scaled), base)}")
    print(f"  every mass and force x {lam:g}, constants held: {_mm(held, base)}")


def sensitivities(effects: tuple[Effect, ...], theta: np.ndarray, base: np.ndarray, step: float = 0.01
                  ) -> tuple[list[str], np.ndarray]:
    """Part 2 and the +2 % column of part 1: J (N x P) = ∂nodes/∂log θ_j over the shared parameters."""
    space = model_space(effects)
    shared = [n for n in space.names[:15] if n not in INERT]
    columns = []
    for name in tqdm(shared, desc="  sensitivities", leave=False):
        j = space.names.index(name)
        up, down = theta.copy(), theta.copy()
        up[j] *= np.exp(step)
        down[j] *= np.exp(-step)
        a, b = _flop(effects, up), _flop(effects, down)
        columns.append(((a - b) / (2 * step)).ravel())
        two = theta.copy()
        two[j] *= 1.02
        print(f"    {name:16s} +2 % alone: {_mm(_flop(effects, two), base)}")
    return shared, np.column_stack(columns)


def report(shared: list[str], jac: np.ndarray, weakest: int) -> None:
    """Singular values as the RMS node change of a 2 % step, and the weakest directions' loadings."""
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    rms = 0.02 * s / np.sqrt(jac.shape[0] / 3)            # per node: 3 coordinates make one distance
    print("  2 % along each singular direction, RMS node change [mm]: " + ", ".join(f"{1e3 * r:.3g}" for r in rms))
    for i in range(1, weakest + 1):
        v = vt[-i] * np.sign(vt[-i][np.argmax(np.abs(vt[-i]))])
        parts = sorted(zip(shared, v, strict=True), key=lambda p: -abs(p[1]))
        print(f"  direction {len(s) - i + 1} ({1e3 * rms[-i]:.3g} mm): "
              + ", ".join(f"{n} {x:+.2f}" for n, x in parts if abs(x) >= 0.1))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lam", type=float, default=1.1, help="the mass scale of part 1")
    ap.add_argument("--weakest", type=int, default=3, help="how many weakest directions to print")
    args = ap.parse_args(argv)
    for label, (effects, sizes) in MODELS.items():
        space = model_space(effects)
        theta = space.nominal.copy()
        for name, value in sizes.items():
            theta[space.names.index(name)] = value
        base = _flop(effects, theta)
        print(f"{label}: 3-s flop at nominal θ")
        symmetry(effects, theta, base, args.lam)
        shared, jac = sensitivities(effects, theta, base)
        report(shared, jac, args.weakest)
    return 0


if __name__ == "__main__":
    sys.exit(main())
