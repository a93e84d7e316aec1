"""The report of a diagnosis: text tables, a JSON record, the final model and figures (matplotlib, Agg).

``model.json`` holds the final model (the mismatch stage's components, the effects measured at rest,
then the effects found) and its θ̂ (physics.model_file), so that ``tensegrid identify --model
DIR/model.json`` identifies with it.

Figures (written to the output directory):

- ``residual_time.png``: ||r_i|| [mm] over time on each held-out trajectory, before (the first
  model) and after (the final model), phases shaded (criticism.residuals);
- ``residual_nodes.png``: RMS residual per node and axis before and after;
- ``ranking.png``: held-out explained fraction of each effect on the first pass, the floor dashed;
- ``signature.png``: the first pass's found effect's signature s_i = x̂_i(with it) - x̂_i(without)
  (with the components a second look let in beside it, criticism.revisit), its norm against the
  residual's component along it, (r_i · s_i)/||s_i||: where the effect explains the residual the
  two curves coincide.
"""
from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from belief.bounds import AT_BOUND_TOLERANCE
from belief.verdicts import plain_reason, rule_of
from criticism.diagnosis import Diagnosis, Pass
from criticism.residuals import residual_dataset
from criticism.wider_box import tested_text
from physics.effects import Effect
from physics.model_file import write_model_file
from physics.parameters import T6_NOMINAL
from physics.trajectory_objective import TrajectoryObjective

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["diagnosis_text", "diagnosis_record", "write_report", "estimate_verdict", "actuator_text"]


def diagnosis_text(d: Diagnosis) -> str:
    """Ranking per pass, the parameters the re-tuning left at a bound (model inadequacy) with what
    re-fitting them in a wider box found (criticism.wider_box), and the held-out error before and
    after, as plain text (after the mismatch stage's, when it ran)."""
    out = actuator_text(d)
    out += [] if d.contact is None else [d.contact.text()]
    out += [] if d.mismatch is None else [d.mismatch.text()]
    read = d.contact.bias if d.contact is not None else None
    out += [f"{'read from the flops' if e is read else 'measured at rest'}: {e.name} ({_measured(e)}), added before "
            "identifying" for e in d.measured]
    scope = (f"held-out trajectories {d.held_out}" if d.held_out
             else "one trajectory: odd windows held out from the effect fit, errors in-sample")
    for k, p in enumerate(d.passes, 1):
        model = "T6" + "".join(f" + {e}" for e in p.effects)
        out.append(f"pass {k}: model {model}; {scope}")
        out.append(p.criticism.table())
        s = p.criticism.structure
        if s:
            ph = ", ".join(f"{n} {v['share']:.0%}" for n, v in s["phases"].items())
            out.append(f"residual share by phase: {ph}; largest on nodes {s['top_nodes']}; "
                       f"by axis " + ", ".join(f"{a} {v:.0%}" for a, v in s["axis_share"].items())
                       + (f"; NaN samples skipped per trajectory {s['skipped']}" if any(s["skipped"]) else ""))
        pinned = tested_text(p.at_bounds, p.wider_box, tolerance=d.settings.get("bound_tolerance", AT_BOUND_TOLERANCE),
                             settable=T6_NOMINAL)
        if pinned:
            out.append(pinned)
        out += _outcome(p)
    return "\n".join(out)


def _measured(effect: Effect) -> str:
    """An effect measured at rest as text: its parameters' measured values and boxes."""
    return "; ".join(f"{q.name}={q.nominal:.4g} {q.unit}, kept within [{q.lower:.4g}, {q.upper:.4g}]"
                     for q in effect.parameters())


def _outcome(p: Pass) -> list[str]:
    """A pass's verdict lines: the effect added, the held-out error E per trajectory before and
    after with the relative change, and the re-identified estimates; or why nothing was added."""
    found, after = p.found, p.held_after
    second = [look.text() for look in p.looks]
    if p.added is None or found is None or after is None:
        return second + [f"verdict: {p.criticism.verdict} (no effect explains enough of the held-out residual "
                         "left by the re-tuned model)"]
    out = second + [f"verdict: found {p.added} ({', '.join(f'{k}={v:.4g}' for k, v in found.values.items())})",
           f"{'held-out':10s} {'E before':>12} {'E after':>12} {'change':>8}"]
    for key, b in p.held_before.items():
        a = after[key]
        out.append(f"{key:10s} {b:12.5g} {a:12.5g} {a / b - 1:+8.1%}")
    tb, ta = sum(p.held_before.values()), sum(after.values())
    out.append(f"{'total':10s} {tb:12.5g} {ta:12.5g} {ta / tb - 1:+8.1%}")
    out.append("re-identified: " + "; ".join(_estimate(n, e) for n, e in p.estimates().items()))
    return out


def estimate_verdict(e: dict[str, Any]) -> str:
    """An estimate's verdict (Pass.estimates), with "at lower/upper bound" when pinned there and
    the reason, in plain words, when the "structure" rule decided it: a rule P cannot show needs its words."""
    side = f" (at {e['at_bound']} bound)" if e.get("at_bound") else ""
    why = f" ({plain_reason(str(e['reason']))})" if rule_of(str(e.get("reason", ""))) == "structure" else ""
    return f"{e.get('verdict', '-')}{side}{why}"


def _estimate(name: str, e: dict[str, Any]) -> str:
    """``name=value`` with the credible interval and verdict when the re-identification has a Belief."""
    if "lower" not in e:
        return f"{name}={e['value']:.4g}"
    return (f"{name}={e['value']:.4g} ({e['level']:.0%} interval [{e['lower']:.4g}, {e['upper']:.4g}], "
            f"{estimate_verdict(e)})")


def actuator_text(d: Diagnosis) -> list[str]:
    """The lines on the actuator read from the encoders (physics.actuator_choice), [] when not read:
    what it found, whether it replaced the motor model, the parameters it leaves inert."""
    if d.actuator is None:
        return []
    out = d.actuator.lines()
    if d.actuator.inert:
        out.append(f"inert under the measured actuator (the model no longer reads them; their intervals say "
                   f"nothing): {', '.join(d.actuator.inert)}")
    return out


def diagnosis_record(d: Diagnosis) -> dict[str, Any]:
    """The JSON-able record of diagnosis.json: settings, and per pass the criticism, θ̃ ("theta"),
    the parameters at a bound after the re-tuning ("at_bounds", belief.bounds.AtBound.as_dict) and
    their test in a wider box ("wider_box", criticism.wider_box.WiderBoxCheck.as_dict, or None),
    the held-out errors and the re-identified estimates, the second look the pass took ("revisit")
    and every second look ("looks", criticism.revisit); "mismatch": the mismatch stage's record or None;
    "measured": the configs of the effects measured at rest; "contact": the contact read from the
    flops (criticism.contact) or None; "actuator": the actuator read from the encoders
    (physics.actuator_choice.ActuatorChoice.as_dict) or None."""
    return {"held_out": d.held_out, "effects": list(d.effects), "settings": d.settings,
            "mismatch": None if d.mismatch is None else d.mismatch.as_dict(),
            "measured": [e.config() for e in d.measured],
            "contact": None if d.contact is None else d.contact.as_dict(),
            "actuator": None if d.actuator is None else d.actuator.as_dict(),
            "passes": [{"effects": list(p.effects), "criticism": p.criticism.as_dict(), "held_before": p.held_before,
                        "added": p.added, "held_after": p.held_after, "estimates": p.estimates(),
                        "theta_after": None if p.theta_after is None
                        else dict(zip(p.names_after, p.theta_after.tolist(), strict=True)),
                        "theta": dict(zip(p.names, p.theta.tolist(), strict=True)),
                        "at_bounds": [a.as_dict() for a in p.at_bounds],
                        "wider_box": None if p.wider_box is None else p.wider_box.as_dict(),
                        "revisit": None if p.revisit is None else p.revisit.as_dict(),
                        "looks": [look.as_dict() for look in p.looks]} for p in d.passes]}


def _objective(d: Diagnosis, trajectories: Sequence[xr.Dataset], effects: Sequence[Effect]) -> TrajectoryObjective:
    """The diagnosis's error (its horizon and windows, serial) on ``trajectories`` with ``effects``."""
    return TrajectoryObjective(list(trajectories), horizon=d.settings["horizon"], loss="squared",
                           windows=d.settings["windows"], effects=effects, n_workers=0)


def _final(d: Diagnosis) -> tuple[list[Effect], np.ndarray]:
    """The final model's effects (the mismatch stage's, those measured at rest, then those found) and θ̂."""
    effects: list[Effect] = list(d.first_model)
    theta = d.passes[0].theta
    for p in d.passes:
        if p.added is not None and p.additions and p.theta_after is not None:
            effects.extend(p.additions)
            theta = p.theta_after
    return effects, theta


def _shade(ax: Axes, res: xr.Dataset) -> None:
    """Shade the samples of ``res`` by phase: actuating orange, contact red."""
    colours = {"actuating": "tab:orange", "contact": "tab:red"}
    t, ph = np.asarray(res["time"].values), np.asarray(res["phase"].values)
    for name, colour in colours.items():
        for i in np.flatnonzero(ph == name):
            ax.axvspan(t[i] - 0.005, t[i] + 0.005, color=colour, alpha=0.08, lw=0)


def _plot_time(before: xr.Dataset, after: xr.Dataset, keys: list[int], path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(keys), 1, figsize=(8, 2.6 * len(keys)), squeeze=False, sharex=True)
    for ax, k in zip(axes[:, 0], keys, strict=True):
        b, a = before.where(before.trajectory == k, drop=True), after.where(after.trajectory == k, drop=True)
        _shade(ax, b)
        ax.plot(b["time"], 1e3 * b["norm"], label="before", color="tab:gray")
        ax.plot(a["time"], 1e3 * a["norm"], label="after", color="tab:blue")
        ax.set_ylabel("||r|| [mm]")
        ax.set_title(f"trajectory {k} (shaded: orange actuating, red contact)", fontsize=9)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_nodes(before: xr.Dataset, after: xr.Dataset, path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3))
    x = np.arange(12)
    for offset, res, label, colour in ((-0.2, before, "before", "tab:gray"), (0.2, after, "after", "tab:blue")):
        rms = 1e3 * np.sqrt((res["residual"] ** 2).sum("axis").mean("sample").values)
        ax.bar(x + offset, rms, width=0.4, label=label, color=colour)
    ax.set_xticks(x)
    ax.set_xlabel("node")
    ax.set_ylabel("RMS ||r|| [mm]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_ranking(d: Diagnosis, path: Path) -> None:
    import matplotlib.pyplot as plt

    crit = d.passes[0].criticism
    names = [c.name for c in crit.ranking]
    values = [max(c.explained, -0.5) for c in crit.ranking]
    colours = ["tab:green" if crit.found is not None and n == crit.found.name else "tab:gray" for n in names]
    fig, ax = plt.subplots(figsize=(8, 3.2))
    ax.barh(names[::-1], values[::-1], color=colours[::-1])
    ax.axvline(max(crit.floor.explained, 0.0), color="k", ls="--", lw=1, label=f"floor ({crit.floor.name})")
    ax.set_xlabel("held-out explained fraction (pass 1)")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_signature(d: Diagnosis, trajectories: Sequence[xr.Dataset], path: Path) -> bool:
    """The signature of pass 1's found effect (and what came in with it) against the residual
    (module docstring); False when pass 1 found nothing."""
    import matplotlib.pyplot as plt

    p = d.passes[0]
    row = p.found
    if row is None:
        return False
    base = _objective(d, trajectories, list(d.first_model))
    with_it = base.with_effects([*d.first_model, *p.additions])
    label = " + ".join(e.name for e in p.additions)
    k = d.held_out[0] if d.held_out else 0
    theta_e = np.asarray(row.theta, float)
    x_b = base.predictions(theta_e[:base.space.dim])[k].values
    x_e = with_it.predictions(theta_e)[k].values
    obs = np.asarray(base.trajectories[k]["nodes"].transpose("time", "node", "axis").values, float)
    s, r = (x_e - x_b).reshape(len(obs), 36), (obs - x_b).reshape(len(obs), 36)
    t = np.asarray(base.trajectories[k]["time"].values)
    norm = np.linalg.norm(s, axis=1)
    along = np.einsum("ij,ij->i", r, s) / np.where(norm > 0, norm, np.nan)
    fig, ax = plt.subplots(figsize=(8, 3))
    ax.plot(t, 1e3 * np.linalg.norm(r, axis=1), color="tab:gray", lw=0.8, label="||r|| (without the effect)")
    ax.plot(t, 1e3 * along, color="tab:blue", label="r along the signature")
    ax.plot(t, 1e3 * norm, color="tab:green", ls="--", label=f"||signature|| of {label}")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("[mm]")
    found = ", ".join(f"{n}={v:.3g}" for n, v in row.values.items())
    ax.set_title(f"trajectory {k}: {label} at {found}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def write_report(d: Diagnosis, trajectories: Sequence[xr.Dataset], out: str | Path) -> list[Path]:
    """Write report.txt, diagnosis.json, model.json and the figures of the module docstring to ``out``;
    returns the paths."""
    import matplotlib

    matplotlib.use("Agg")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "report.txt", out / "diagnosis.json"]
    paths[0].write_text(diagnosis_text(d) + "\n")
    paths[1].write_text(json.dumps(diagnosis_record(d), indent=1, default=float))
    effects, theta = _final(d)
    paths.append(out / "model.json")
    names = d.passes[-1].names_after if d.passes[-1].theta_after is not None else d.passes[-1].names
    write_model_file(paths[-1], effects, dict(zip(names, theta.tolist(), strict=True)))
    before = residual_dataset(_objective(d, trajectories, list(d.first_model)), d.passes[0].theta)
    after = residual_dataset(_objective(d, trajectories, effects), theta)
    keys = d.held_out or [0]
    _plot_time(before, after, keys, out / "residual_time.png")
    held_b = before.where(before.trajectory.isin(keys), drop=True)
    held_a = after.where(after.trajectory.isin(keys), drop=True)
    _plot_nodes(held_b, held_a, out / "residual_nodes.png")
    _plot_ranking(d, out / "ranking.png")
    paths += [out / "residual_time.png", out / "residual_nodes.png", out / "ranking.png"]
    if _plot_signature(d, trajectories, out / "signature.png"):
        paths.append(out / "signature.png")
    return paths
