"""What ``tensegrid identify`` runs on: the data or the toy, the prior box, what the user knows, the
model's effects and the actuator read from the encoders, checked and built before any search.

The order matters for the user: the prior box and --measured/--fix are checked before the data are
loaded, the data files as by ``tensegrid check`` (unless --skip-checks), then the actuator is read
from the encoder readings (physics.actuator_choice) and, when its law replaces the motor model, the
motor parameters it makes inert are held at nominal (MeasurementPrior.with_inert)."""
from __future__ import annotations

import argparse
import contextlib
from typing import TYPE_CHECKING, NamedTuple

from physics.state_estimation import StateEstimator

if TYPE_CHECKING:                   # the engine loads only when a command needs it
    import numpy as np
    import xarray as xr

    from physics.actuator_choice import ActuatorChoice
    from physics.effects import Effect
    from physics.measurements import MeasurementPrior
    from physics.model_options import ModelOptions
    from physics.objective import Objective
    from physics.parameters import ParameterSpace
    from physics.push import PushObjective

__all__ = ["Problem", "build_problem", "model_effects", "default_space"]


def _push_objective(seed: int, space: ParameterSpace) -> tuple[PushObjective, np.ndarray]:
    import numpy as np

    from physics.push import PushObjective, generate_push_data

    truth = np.array([1.0, 0.4])
    impulses, observed = generate_push_data(truth, n=8, noise_std=0.05, seed=seed)
    return PushObjective(impulses, observed, space=space, noise_std=0.05), truth


def _data_truth(datasets: list[xr.Dataset], space: ParameterSpace) -> np.ndarray | None:
    """θ that generated the data (the files' ``theta`` variable), if every file carries the same one."""
    import numpy as np

    thetas = [ds["theta"] for ds in datasets if "theta" in ds]
    if not datasets or len(thetas) != len(datasets):
        return None
    try:
        first = np.asarray(thetas[0].sel(parameter=list(space.names)).values, dtype=float)
    except (KeyError, ValueError):
        return None
    same = all(np.allclose(t.sel(parameter=list(space.names)).values, first) for t in thetas[1:])
    return first if same else None


class Problem(NamedTuple):
    """What identify runs on: the objective, the true θ (simulated data) or None, the data, what the
    user knows (with the parameters the model no longer reads held), the model's effects, and the
    actuator read from the encoders (None: not read)."""

    objective: Objective
    truth: np.ndarray | None
    datasets: list[xr.Dataset]
    known: MeasurementPrior
    effects: tuple[Effect, ...]
    actuator: ActuatorChoice | None


def _read_actuator(args: argparse.Namespace, datasets: list[xr.Dataset], space: ParameterSpace,
                   effects: tuple[Effect, ...], options: ModelOptions | None) -> ActuatorChoice | None:
    """The actuator read from the data's encoder readings (physics.actuator_choice), unless an effect
    of --effects or --model already replaces the actuator (it stands: a model file carries a measured
    one) or --actuator model."""
    from physics.actuator_choice import choose_actuator
    from physics.effects import MeasuredActuator

    named = {e.name for e in effects}
    if named & (MeasuredActuator.replaces | {MeasuredActuator.name}):
        return None
    return choose_actuator(datasets, space, mode=args.actuator, options=options)


def build_problem(args: argparse.Namespace, effects: tuple[Effect, ...], cleanup: contextlib.ExitStack) -> Problem:
    """The :class:`Problem` of the data files or the toy, over the prior box of --nominal, --bounds and
    --params with --measured and --fix checked on it (all before the data are loaded), with ``effects``
    and the actuator read from the encoders; a trajectory objective's workers close with ``cleanup``."""
    from physics.measurements import measurement_prior_from_args
    from physics.prior_box import prior_box_from_args

    space = prior_box_from_args(args, default_space(args, effects))
    known = measurement_prior_from_args(args, space)        # MeasurementError before the data are loaded
    if args.toy == "push":
        push, truth = _push_objective(args.seed, space)
        return Problem(known.hold(push), known.free(truth), [], known, effects, None)
    from physics.predictor import dt_option
    from physics.trajectory import load_trajectory
    from physics.trajectory_objective import TrajectoryObjective

    datasets = [load_trajectory(path) for path in args.data]
    options = dt_option(getattr(args, "dt", None), datasets, name="--dt")   # StepSizeError before any evaluation
    if not getattr(args, "skip_checks", False):
        from physics.cli_check import preflight

        preflight(datasets, args.data, "identify", known.space)     # DataCheckError, ParameterError: no evaluation
    actuator = _read_actuator(args, datasets, space, effects, options)
    if actuator is not None and actuator.effect is not None:
        effects, known = effects + (actuator.effect,), known.with_inert(actuator.inert)
    trajectories = cleanup.enter_context(TrajectoryObjective(
        datasets, space=space, horizon=1, loss=args.loss, windows=args.windows, options=options,
        n_workers=args.workers if args.workers > 1 else 0, effects=effects, states=StateEstimator(method=args.states)))
    data_truth = _data_truth(datasets, trajectories.space)
    return Problem(known.hold(trajectories), None if data_truth is None else known.free(data_truth), datasets, known,
                   effects, actuator)


def model_effects(args: argparse.Namespace) -> tuple[Effect, ...]:
    """The effects of --effects or --model (physics.model_file), () without them."""
    from physics.errors import ParameterError
    from physics.model_file import effects_by_name, read_model_file

    effects, model = getattr(args, "effects", None), getattr(args, "model", None)
    if (effects or model) and args.toy is not None:
        raise ParameterError("--effects and --model extend the T6 model; the push toy has none. Drop them or "
                             "pass data files.")
    return effects_by_name(effects) if effects else read_model_file(model) if model else ()


def default_space(args: argparse.Namespace, effects: tuple[Effect, ...]) -> ParameterSpace:
    """The parameter space before --nominal, --bounds and --params: the push toy's, or the T6's with
    ``effects`` (those of --effects or --model)."""
    from physics.effects import model_space
    from physics.push import push_space

    return push_space() if args.toy == "push" else model_space(effects)
