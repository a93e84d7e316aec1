"""``tensegrid simulate``: the T6 at θ under the flop controller, or replaying a recording.

θ is built in layers, later ones winning: the nominal values; ``--model DIR/model.json`` (the
effects ``tensegrid diagnose`` ended with and its θ̂, physics.model_file); ``--from DIR/result.nc``
(the best θ of ``tensegrid identify`` with the values it fixed, and, without ``--model``, the
effects it identified, physics.result_file); ``--theta`` and ``--effect`` (which also switches its
effect on). ``--replay DATA.nc`` starts from the recording's first state and sends its commands
(physics.replay); it writes the rollout, a plot against the recording and the open-loop errors.
Every input is read and checked before anything is simulated, and ``--out`` is created only once
the simulation has run, so a mistake leaves nothing behind.
"""
from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from physics.errors import ParameterError

if TYPE_CHECKING:
    from physics.effects import Effect
    from physics.replay import Replay

__all__ = ["register_simulate", "SimulatedModel", "FlopOptions", "resolve_model"]


@dataclass(frozen=True)
class FlopOptions:
    """The flop run's options, which a replay does not take: goal ``heading`` [rad from +x], number
    of ``flops`` (0 = rest), ``period`` [s] per flop, sampling ``rate`` [Hz], position ``noise`` [m]
    and its ``seed``; the defaults are the command line's."""

    heading: float = 0.0
    flops: int = 1
    period: float = 3.0
    rate: float = 100.0
    noise: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if self.flops < 0:
            raise ParameterError(f"--flops must be 0 (rest) or more, got {self.flops}.")


def _parse_assignments(items: Sequence[str], option: str) -> dict[str, float]:
    """``NAME=VALUE`` items as a mapping; ArgumentTypeError names ``option`` for a malformed one."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise argparse.ArgumentTypeError(f"{option} expects NAME=VALUE, got {item!r}")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} {name}: {value!r} is not a number") from None
    return out


def _with_effects(effects: tuple[Effect, ...], values: dict[str, float]) -> tuple[Effect, ...]:
    """``effects`` and, after them in catalog order, those owning a parameter of ``values`` (--effect)
    that they lack (physics.effects.EFFECT_TYPES)."""
    from physics.effects import EFFECT_TYPES

    owners = {p.name: cls for cls in EFFECT_TYPES.values() for p in cls().parameters()}
    unknown = sorted(set(values) - set(owners))
    if unknown:
        raise ParameterError(f"--effect: unknown effect parameter(s) {unknown}; known: {sorted(owners)}.")
    have = {type(e) for e in effects}
    wanted = {owners[name] for name in values} - have
    return effects + tuple(cls() for cls in EFFECT_TYPES.values() if cls in wanted)


@dataclass(frozen=True)
class SimulatedModel:
    """The model a run simulates: ``effects``, θ by name (every parameter of the T6 and its effects)
    and ``sources``, where the values came from (``"nominal"``, ``"--model PATH"``, ...)."""

    effects: tuple[Effect, ...]
    theta: dict[str, float]
    sources: tuple[str, ...]

    def __post_init__(self) -> None:
        from physics.effects import model_space

        names = model_space(self.effects).names
        if tuple(self.theta) != names:
            raise ParameterError(f"SimulatedModel.theta must name {list(names)} in order, got {list(self.theta)}.")


def resolve_model(args: argparse.Namespace) -> SimulatedModel:
    """The effects and θ of --model, --from, --theta and --effect, layered as the module docstring says;
    ParameterError for a file that is not what it should be or a name the model lacks."""
    from physics.effects import model_space
    from physics.model_file import read_model_file, read_model_theta
    from physics.result_file import read_identified_theta

    overrides, effect_values = _parse_assignments(args.theta, "--theta"), _parse_assignments(args.effect, "--effect")
    effects: tuple[Effect, ...] = ()
    layers: list[tuple[str, dict[str, float]]] = []
    if args.model:
        effects = read_model_file(args.model)
        layers.append((f"--model {args.model}", read_model_theta(args.model)))
    if args.result:
        identified = read_identified_theta(args.result)
        effects = effects if args.model else identified.effects
        layers.append((f"--from {args.result}", dict(identified.values)))
    effects = _with_effects(effects, effect_values)
    space = model_space(effects)
    names = ", ".join(e.name for e in effects) or "none"
    values: dict[str, float] = {}
    for source, layer in layers:
        unknown = sorted(set(layer) - set(space.names))
        if unknown:
            hint = ("pass the model.json its identification used, or leave --model out" if args.model and args.result
                    else "the file describes another model")
            raise ParameterError(f"{source}: parameter(s) {unknown} are not in the simulated model (effects: {names}); "
                                 f"{hint}.")
        values.update(layer)
    unknown = sorted(set(overrides) - set(space.names))
    if unknown:
        raise ParameterError(f"--theta: Unknown parameter name(s) {unknown}; valid names are {list(space.names)}.")
    theta = space.as_array({**values, **overrides, **effect_values}, check_bounds=False)
    given = [source for source, _ in layers] + ["--theta"] * bool(overrides) + ["--effect"] * bool(effect_values)
    return SimulatedModel(effects=effects, theta=dict(zip(space.names, theta.tolist(), strict=True)),
                          sources=tuple(given) or ("nominal",))


def _flop_options(args: argparse.Namespace) -> FlopOptions:
    """The flop options given, the defaults for the others; ParameterError when any is given with --replay."""
    given = {"--heading": args.heading, "--flops": args.flops, "--period": args.period, "--rate": args.rate,
             "--noise": args.noise, "--seed": args.seed}
    named = [option for option, value in given.items() if value is not None]
    if args.replay and named:
        raise ParameterError(f"--replay sends the recording's commands at its rate from its first state; "
                             f"{', '.join(named)} belong to the flop run: leave them out.")
    default = FlopOptions()
    return FlopOptions(heading=default.heading if args.heading is None else args.heading,
                       flops=default.flops if args.flops is None else args.flops,
                       period=default.period if args.period is None else args.period,
                       rate=default.rate if args.rate is None else args.rate,
                       noise=default.noise if args.noise is None else args.noise,
                       seed=default.seed if args.seed is None else args.seed)


def _run_simulate(args: argparse.Namespace) -> int:
    from physics.outputs import check_output_dir

    check_output_dir(args.out)
    flop = _flop_options(args)
    model = resolve_model(args)
    return _run_replay(args, model) if args.replay else _run_flop(args, flop, model)


def _run_flop(args: argparse.Namespace, flop: FlopOptions, model: SimulatedModel) -> int:
    """Simulate ``flop`` at the model for --duration; write trajectory.nc and trajectory.png."""
    from physics.controllers import FlopController, HoldController
    from physics.outputs import make_output_dir
    from physics.plotting import plot_trajectory
    from physics.simulation import simulate
    from physics.trajectory import save_trajectory

    controller = (HoldController() if flop.flops == 0 else
                  FlopController(flop.heading, flops=flop.flops, period=flop.period))
    duration = args.duration if args.duration is not None else max(1.0, flop.flops * flop.period)
    ds = simulate(model.theta, controller=controller, duration=duration, sample_rate=flop.rate,
                  noise=flop.noise, seed=flop.seed, effects=model.effects)
    out = make_output_dir(args.out)
    nc = save_trajectory(ds, out / "trajectory.nc")
    png = plot_trajectory(ds, out / "trajectory.png")
    com = ds["nodes"].mean("node").values
    moved = com[-1, :2] - com[0, :2]
    print(_model_text(model))
    print(f"simulated {duration:.1f} s ({len(ds.time)} samples at {flop.rate:g} Hz); "
          f"centre of mass moved ({moved[0]:+.3f}, {moved[1]:+.3f}) m; peak tension {float(ds.tension.max()):.0f} N")
    print(f"wrote {nc}\nwrote {png}")
    return 0


def _model_text(model: SimulatedModel) -> str:
    """Where θ came from and the effects switched on, one line."""
    effects = ", ".join(e.name for e in model.effects)
    return f"θ from {', '.join(model.sources)}" + (f"; effects {effects}" if effects else "")


def _error_text(run: Replay) -> str:
    """The open-loop errors at OPEN_LOOP_TIMES in mm, each past the replay's end said so."""
    parts = [f"{a:g} s {e * 1000:.3g} mm" if math.isfinite(e) else
             (f"{a:g} s past the end ({run.duration:.2f} s)" if a > run.duration else f"{a:g} s no recorded nodes")
             for a, e in run.errors().items()]
    return "open-loop error (RMS node distance): " + ", ".join(parts)


def _run_replay(args: argparse.Namespace, model: SimulatedModel) -> int:
    """Replay --replay at the model; write trajectory.nc, replay.png and replay.json."""
    from physics.outputs import make_output_dir
    from physics.plotting import plot_observed_vs_predicted
    from physics.replay import replay
    from physics.trajectory import load_trajectory, save_trajectory

    recording = load_trajectory(args.replay)
    run = replay(recording, model.theta, effects=model.effects, duration=args.duration)
    text = _error_text(run)
    out = make_output_dir(args.out)
    nc = save_trajectory(run.rollout, out / "trajectory.nc")
    png = plot_observed_vs_predicted(run.observed, {"replay": run.rollout["nodes"]}, out / "replay.png",
                                     title=f"{Path(args.replay).name} replayed open loop",
                                     note=f"{text}; the bottom panel's ||x - x̂|| sums over the 12 nodes: √12 × "
                                          "the RMS node distance")
    record = {"recording": str(args.replay), "theta_from": list(model.sources), "theta": model.theta,
              "effects": [e.config() for e in model.effects], "start_sample": run.start,
              "start_time_s": float(run.rollout["time"].values[0]), "duration_s": run.duration,
              "initial_velocities": run.velocities,
              "open_loop_error_m": {f"{a:g}": (e if math.isfinite(e) else None) for a, e in run.errors().items()},
              "error_definition": "sqrt(mean over the 12 nodes of |x - x_replay|^2) at the sample nearest t "
                                  "after the start"}
    (out / "replay.json").write_text(json.dumps(record, indent=1) + "\n")
    print(_model_text(model))
    print(f"replayed {args.replay} from its sample {run.start} for {run.duration:.2f} s "
          f"({run.velocities} starting velocities)")
    print(f"{text}\nwrote {nc}\nwrote {png}\nwrote {out / 'replay.json'}")
    return 0


def register_simulate(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``tensegrid simulate``."""
    p = subparsers.add_parser("simulate", help="simulate the SUPERball flopping or replay a recording; write "
                                               "trajectory.nc and a picture",
                              description=__doc__)
    p.add_argument("--out", default="out/simulate", help="output folder (default: out/simulate)")
    p.add_argument("--theta", nargs="*", default=[], metavar="NAME=VALUE",
                   help="parameter values in SI, e.g. damping=180 pretension=140 (override --from and --model)")
    p.add_argument("--effect", nargs="*", default=[], metavar="NAME=VALUE",
                   help="switch on effects by their parameters, e.g. actuator_delay=0.08 (physics.effects; "
                        "the recording does not name them)")
    p.add_argument("--from", dest="result", default=None, metavar="RESULT.nc",
                   help="start θ from the best θ of tensegrid identify's result.nc (with its fixed values and effects)")
    p.add_argument("--model", default=None, metavar="MODEL.json",
                   help="the effects and θ of tensegrid diagnose's model.json (its effects replace --from's)")
    p.add_argument("--replay", default=None, metavar="DATA.nc",
                   help="replay this recording open loop from its first state; writes replay.png and replay.json "
                        "with the open-loop error at 0.3, 0.5 and 1 s")
    p.add_argument("--heading", type=float, default=None, help="goal direction in radians from +x (default 0)")
    p.add_argument("--flops", type=int, default=None, help="number of flops (0 = just rest; default 1)")
    p.add_argument("--period", type=float, default=None, help="seconds per flop (default 3)")
    p.add_argument("--duration", type=float, default=None,
                   help="seconds to record (default flops x period; with --replay at most the recording's)")
    p.add_argument("--rate", type=float, default=None, help="sampling rate in Hz (default 100)")
    p.add_argument("--noise", type=float, default=None, help="std of position noise in m (default 0)")
    p.add_argument("--seed", type=int, default=None, help="seed of the noise (default 0)")
    p.set_defaults(func=_run_simulate)
