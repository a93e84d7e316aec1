"""Tutorial: identify the 1-D push toy, read the posterior P, plot it.

The push toy (Zhu et al. 2018, Sec. IV-C) is a point of mass m [kg] pushed with impulse J [N*s]
against friction mu; it slides S = J^2 / (2 m^2 mu) [m]. Only m^2 mu is identifiable, so the
posterior must be a ridge, not a point: the reason tensegrid returns a distribution.

Part 2 (``--t6``) does the same for the SUPERball: it simulates a flop with parameters θ* drawn
inside the ±10 % box, then identifies θ* from the node trajectory with REMBO (15 -> 5 dimensions,
the paper's setting) and prints which parameters the data pin down.

Run::

    .venv/bin/python docs/tutorial_identify.py --out out/tutorial          # push toy (about 10 s)
    .venv/bin/python docs/tutorial_identify.py --t6 --out out/tutorial     # + the T6 (about 1 min)
    .venv/bin/python docs/tutorial_identify.py --quick --out /tmp/tut      # what the test suite runs

(``TENSEGRID_QUICK=1`` also selects the quick mode.) Writes ``posterior.png``,
``marginals.png``, ``error.png`` and ``result.nc`` (and ``t6_*`` files) to ``--out``.
"""
from __future__ import annotations

import argparse
import os

import numpy as np

from belief import Grid, IdentificationResult, credible_mask, identify
from belief.plots import plot_error_trace, plot_marginals, plot_posterior_2d
from embeddings import Identity
from physics.push import PushObjective, generate_push_data, push_space


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="small grid and budget (test suite)")
    parser.add_argument("--out", default="out/tutorial_identify")
    parser.add_argument("--t6", action="store_true", help="also identify the SUPERball from a simulated flop")
    args = parser.parse_args(argv)
    quick = args.quick or os.environ.get("TENSEGRID_QUICK") == "1"
    os.makedirs(args.out, exist_ok=True)

    # 1. Data: 8 pushes of a point with m = 1 kg, mu = 0.4, displacements measured with 5 cm noise.
    space = push_space()                                   # m in [0.5, 1.5] kg, mu in [0.1, 1.0]
    truth = np.array([1.0, 0.4])
    impulses, observed = generate_push_data(truth, n=8, noise_std=0.05, seed=0)

    # 2. The objective E(θ) = sum_k (S(θ; J_k) - S_obs_k)^2. Knowing the noise makes
    #    exp(-E / (2 sigma^2)) the exact likelihood, which the 'likelihood' posterior uses.
    objective = PushObjective(impulses, observed, space=space, noise_std=0.05)

    # 3. Where to search: the identity decoder (the latent box is the unit square of (m, mu))
    #    and a regular grid of cells over it. P will be a distribution over these cells.
    decoder = Identity(space)
    grid = Grid.for_decoder(decoder, points_per_dim=21 if quick else 41)

    # 4. Algorithm 1: Bayesian optimization over the cells, with a journal so that a killed run
    #    resumes where it stopped (delete the file to start afresh).
    journal = os.path.join(args.out, "journal.sqlite")
    if os.path.exists(journal):
        os.remove(journal)
    result = identify(objective, decoder, grid, budget=15 if quick else 40, seed=0, journal=journal,
                      progress=not quick)

    # 5. Read the posterior.
    print(result.summary())
    P = result.posterior                                   # DataArray over (z0, z1), sums to 1
    theta = decoder.decode(grid.points)                    # cell centres in θ units, n x 2
    region = credible_mask(P.values.ravel(), level=0.9)       # 90 % highest-posterior-density cells
    ridge = theta[:, 0] ** 2 * theta[:, 1]
    p = P.values.ravel()
    print(f"90 % region: {region.sum()} of {grid.size} cells; m spans {np.ptp(theta[region, 0]):.2f} kg in it")
    print(f"m^2 mu: truth {truth[0] ** 2 * truth[1]:.3f}, posterior mean {p @ ridge:.3f} "
          f"+- {np.sqrt(p @ (ridge - p @ ridge) ** 2):.3f} kg^2")
    # The belief: P, the decoded cells, a verdict per parameter with its reason, draws of θ.
    belief = result.belief
    for name, (verdict, reason) in belief.verdicts.items():
        print(f"{name}: {verdict} ({reason})")
    draws = belief.sample(1000, seed=0)                    # 1000 x 2 draws of θ from P
    print(f"m^2 mu over 1000 draws: {np.mean(draws[:, 0] ** 2 * draws[:, 1]):.3f} kg^2")

    # 6. Plot and save.
    plot_posterior_2d(P, os.path.join(args.out, "posterior.png"), decoder=decoder,
                      evaluated=result.history["z"].values, truth=truth,
                      ridge=lambda th: th[:, 0] ** 2 * th[:, 1],
                      title="push toy: P over (m, mu); red line m^2 mu = truth")
    plot_marginals(P, theta, space, os.path.join(args.out, "marginals.png"), marginals=result.marginals,
                   truth=truth)
    plot_error_trace(result, os.path.join(args.out, "error.png"))
    result.save(os.path.join(args.out, "result.nc"))
    back = IdentificationResult.load(os.path.join(args.out, "result.nc"))
    assert np.array_equal(back.posterior.values, P.values)
    assert np.array_equal(back.belief.sample(5, seed=1), belief.sample(5, seed=1))  # same belief after the file
    print(f"wrote {args.out}/posterior.png, marginals.png, error.png, result.nc")
    if args.t6:
        t6(args.out, quick=quick)
    return 0


def t6(out: str, *, quick: bool) -> None:
    """Part 2: the SUPERball. Same three objects (objective, decoder, grid), 15 parameters."""
    from embeddings import REMBO
    from physics import FlopController, ParameterSpace, TrajectoryObjective, simulate

    space = ParameterSpace.t6()                                # 15 parameters, nominal ± 10 %
    theta_star = space.sample(1, seed=42)[0]
    data = simulate(theta_star, controller=FlopController(heading=0.0), duration=0.5 if quick else 2.0)
    # one-step-ahead error over the trajectory, sum of squared node errors (the likelihood mode's model)
    with TrajectoryObjective(data, loss="squared", n_workers=0) as objective:
        decoder = REMBO(space, dim=3 if quick else 5, seed=0)    # A ~ N(0, 1) of 15 x d
        grid = Grid.for_decoder(decoder, points_per_dim=5 if quick else 9)
        result = identify(objective, decoder, grid, budget=8 if quick else 60, seed=0, progress=not quick)
        print(result.summary(truth=theta_star))
        print(f"E at nominal {objective(space.nominal):.4g}, at the best θ {result.best_error:.4g}, "
              f"at θ* {objective(theta_star):.4g}")
    m = result.marginals
    err = (m["mean"].values - theta_star) / (space.upper - space.lower)
    for name, e, verdict in zip(space.names, err, m["verdict"].values, strict=True):
        print(f"  {name:<16} posterior mean - θ* = {100 * e:+6.1f} % of the box ({verdict})")
    plot_marginals(result.posterior, decoder.decode(grid.points), space, os.path.join(out, "t6_marginals.png"),
                   marginals=m, truth=theta_star)
    plot_error_trace(result, os.path.join(out, "t6_error.png"))
    result.save(os.path.join(out, "t6_result.nc"))


if __name__ == "__main__":
    raise SystemExit(main())
