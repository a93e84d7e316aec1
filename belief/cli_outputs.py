"""What ``tensegrid identify`` writes into ``--out`` (belief.cli): the result file, the summary, the
tables (marginals, history), the figures and the one-page report."""
from __future__ import annotations

import argparse
import json
import os
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    import xarray as xr

    from belief.grid import CandidateSet
    from belief.result import IdentificationResult
    from embeddings.base import Decoder
    from physics.effects import Effect
    from physics.measurements import MeasurementPrior
    from physics.parameters import ParameterSpace

__all__ = ["write_outputs", "plot_rollouts", "actuator_lines"]


def actuator_lines(result: IdentificationResult) -> list[str]:
    """The summary's lines on the actuator read from the encoders (physics.actuator_choice), [] when
    it was not read."""
    record = result.config.get("actuator")
    return [str(line) for line in record["lines"]] if record else []


def write_outputs(args: argparse.Namespace, result: IdentificationResult, decoder: Decoder, grid: CandidateSet,
                  truth: np.ndarray | None, datasets: list[xr.Dataset], effects: tuple[Effect, ...], *,
                  known: MeasurementPrior | None = None) -> None:
    """result.nc, summary.txt, marginals.csv, history.csv, prior_box.json (a --params file of the run's
    box), the figures and report.html into ``args.out``. ``known``: what the user measured and fixed (its
    block ends summary.txt; the rollouts insert the fixed values)."""
    import numpy as np
    import pandas as pd

    from belief.errors import BeliefError
    from belief.html_report import write_identify_report
    from belief.plots import plot_error_trace, plot_marginals, plot_pairs, plot_posterior_2d

    belief = result.belief
    if belief is None:
        raise BeliefError("the identification returned no belief; the command line writes its posterior.")
    out, space, P, marginals = args.out, decoder.space, belief.P, belief.marginals()
    result.save(os.path.join(out, "result.nc"))
    with open(os.path.join(out, "summary.txt"), "w") as fh:
        user = "" if known is None else known.summary()        # what the user measured and fixed
        fh.write("\n".join(filter(None, [result.summary(truth=truth), user, *actuator_lines(result)])) + "\n")
    marginals.to_dataframe().to_csv(os.path.join(out, "marginals.csv"))
    with open(os.path.join(out, "prior_box.json"), "w") as fh:
        json.dump(result.config["prior_box"], fh, indent=1)
    h = result.history
    hist_tab = {"evaluation": h["evaluation"].values, "error": h["error"].values, "seconds": h["seconds"].values,
                "status": h["status"].values}
    hist_tab.update({name: h["theta"].values[:, j] for j, name in enumerate(space.names)})
    pd.DataFrame(hist_tab).to_csv(os.path.join(out, "history.csv"), index=False)
    plot_error_trace(result, os.path.join(out, "error_vs_evaluations.png"), label=f"best so far ({args.preset})")
    plot_marginals(P, decoder.decode(np.asarray(grid.points)), space,
                   os.path.join(out, "posterior_marginals.png"), marginals=marginals, truth=truth)
    if P.ndim == 2 and P.dims == ("z0", "z1"):
        plot_posterior_2d(P, os.path.join(out, "posterior_2d.png"), decoder=decoder,
                          evaluated=h["z"].values, truth=truth)
    if datasets:
        title = (f"observed vs rollout predictions: {os.path.basename(args.data[0])} (first of {len(datasets)} files)"
                 if len(datasets) > 1 else "")
        best, mean = np.asarray(result.best_theta.values), np.asarray(marginals["mean"].values)
        whole = space
        if known is not None:           # the fixed parameters back in: the rollouts simulate the whole model
            whole, best, mean = known.space, known.full(best), known.full(mean)
        plot_rollouts(datasets[0], whole, best, mean, os.path.join(out, "observed_vs_predicted.png"), effects,
                      title=title)
    plot_pairs(belief, os.path.join(out, "pairs.png"), truth=truth)
    write_identify_report(out, result, args, datasets, truth=truth)


def plot_rollouts(dataset: xr.Dataset, space: ParameterSpace, best: np.ndarray, mean: np.ndarray, path: str,
                  effects: tuple[Effect, ...], *, title: str = "") -> None:
    """Observed centre of mass vs open-loop rollouts at the nominal, ``best`` and posterior-``mean`` θ
    (D,), for one trajectory; the figure says why when the best θ's rollout drifts further than the
    nominal one's."""
    from belief.plots import rollout_note
    from physics.errors import PhysicsError
    from physics.plotting import plot_observed_vs_predicted, rollout_errors
    from physics.trajectory_objective import TrajectoryObjective

    thetas = {"nominal": space.nominal, "best": best, "posterior mean": mean}
    preds = {}
    with TrajectoryObjective([dataset], horizon="rollout", n_workers=0, effects=effects) as roll:
        for name, th in thetas.items():
            try:
                preds[name] = roll.predictions(th)[0]
            except PhysicsError as exc:  # a rollout may diverge; say so and draw the others
                print(f"tensegrid identify: rollout at the {name} theta diverged ({exc}); not drawn", file=sys.stderr)
    if preds:
        plot_observed_vs_predicted(dataset, preds, path, title=title or "observed vs rollout predictions",
                                   note=rollout_note(rollout_errors(dataset, preds)))
