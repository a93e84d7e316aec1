"""``DIR/report.html`` of ``tensegrid diagnose``: the diagnosis as one self-contained page to hand to a
colleague (belief.html_report's :class:`~belief.html_report.Page`: inline CSS, figures embedded as
base64 PNG data URIs).

It says what was run (the command with every option, the settings, the data files with their checks,
physics.checks), the outcome of each pass (the ranking of the effects against the floor, the effect
added and the held-out error before and after, the re-identified effect parameters, the parameters
the re-tuning left at a bound), the first identification's parameters with their verdicts in plain
words, the figures of :mod:`criticism.report`, and how to reproduce the run.
"""
from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from belief.bounds import AT_BOUND_TOLERANCE
from belief.html_report import Page, command_line, data_section, parameter_table, reproduce_section
from criticism.candidate import place_text, values_text
from criticism.diagnosis import Diagnosis, Pass
from criticism.report import actuator_text, diagnosis_text, estimate_verdict
from criticism.wider_box import tested_text
from physics.parameters import T6_NOMINAL

__all__ = ["write_diagnose_report"]

_FIGURES = (
    ("residual_time.png", "||r|| over time on each held-out trajectory, before (the first model) and after (the "
                          "final model); shaded: orange actuating, red contact."),
    ("residual_nodes.png", "RMS residual per node on the held-out data, before and after."),
    ("ranking.png", "What each effect explains of the held-out residual on the first pass; dashed: the floor, "
                    "what re-tuning the model's own parameters explains."),
    ("signature.png", "The found effect's signature (how the prediction moves when the effect, with any component "
                      "the second look let in beside it, is switched on at its fitted size) against the "
                      "residual's component along it: where the effect explains the residual, the two curves "
                      "coincide."),
)


def _ranking(page: Page, p: Pass) -> None:
    """The pass's ranking: the floor, then each effect with its evidence, explained fraction and estimate."""
    crit = p.criticism
    rows: list[list[Any]] = [[f"floor: {crit.floor.name}", crit.floor.evidence, f"{crit.floor.explained:.1%}",
                              f"{len(crit.floor.values)} parameters moved"]]
    classes = [""]
    for k, c in enumerate(crit.ranking, 1):
        found = p.found is not None and c.name == p.found.name
        rows.append([f"{k}. {c.name}" + (" (found)" if found else ""), c.evidence, f"{c.explained:.1%}",
                     values_text(c.values) + place_text(c)])
        classes.append("identified" if found else "")
    page.table(["effect", "evidence (ΔBIC over the floor)", "held-out residual explained", "estimate"], rows,
               classes=classes)


def _held_out(page: Page, p: Pass) -> None:
    """The held-out error E per trajectory before and after the effect was added."""
    after = p.held_after or {}
    rows: list[list[Any]] = [[key, b, after[key], f"{after[key] / b - 1:+.1%}"] for key, b in p.held_before.items()]
    tb, ta = sum(p.held_before.values()), sum(after.values())
    rows.append(["total", tb, ta, f"{ta / tb - 1:+.1%}"])
    page.table(["held-out", "E before [m²]", "E after [m²]", "change"], rows)


def _pass(page: Page, k: int, p: Pass, d: Diagnosis) -> None:
    """One pass: its model, ranking, outcome, the re-identified effect parameters and the pinned parameters."""
    page.subsection(f"Pass {k}: model T6" + "".join(f" + {e}" for e in p.effects))
    _ranking(page, p)
    for look in p.looks:
        line = look.text()
        page.paragraph(f"{line[0].upper()}{line[1:]} (docs/diagnose.md, \"A second look at the stage\").")
    if p.added is None or p.held_after is None:
        page.paragraph(f"Verdict: {p.criticism.verdict}. No effect explains enough of the held-out residual left by "
                       "the re-tuned model, so none was added.")
    else:
        page.paragraph(f"Verdict: found {p.added}; adding it changes the held-out error by "
                       f"{-(p.reduction or 0.0):+.1%}.")
        _held_out(page, p)
        estimates = p.estimates()
        rows = [[n, e["value"], f"[{e['lower']:.4g}, {e['upper']:.4g}]" if "lower" in e else "-",
                 estimate_verdict(e)]
                for n, e in estimates.items()]
        page.table(["re-identified", "value", "interval", "verdict"], rows)
    block = tested_text(p.at_bounds, p.wider_box, tolerance=d.settings.get("bound_tolerance", AT_BOUND_TOLERANCE),
                        settable=T6_NOMINAL)
    if block:
        page.paragraph(block, kind="warning")


def _settings(d: Diagnosis) -> list[list[Any]]:
    """(setting, value) rows: the held-out trajectories, the effects tried and the objective's settings."""
    held = (", ".join(str(k) for k in d.held_out) if d.held_out
            else "none (one trajectory: odd windows held out from the effect fit, errors in-sample)")
    rows: list[list[Any]] = [["held-out trajectories", held]]
    for key, value in d.settings.items():
        rows.append([key, ", ".join(str(v) for v in value) if isinstance(value, (list, tuple)) else str(value)])
    return rows


def write_diagnose_report(out: str | Path, d: Diagnosis, trajectories: Sequence[xr.Dataset],
                          args: argparse.Namespace) -> Path:
    """Write ``out/report.html`` of a diagnose run (module docstring) from the diagnosis, the loaded
    ``trajectories`` (``args.data``) and the command line's ``args``; the figures already in ``out``
    (criticism.report.write_report) are embedded."""
    out = Path(out)
    page = Page(f"tensegrid diagnose: {len(trajectories)} trajectories")
    found = d.found
    page.paragraph(f"Effects found and added: {', '.join(found)}." if found else
                   "No effect was found: nothing in the catalog explains enough of the held-out residual.")
    page.section("What was run")
    command = command_line("diagnose", args)
    page.code(command)
    page.table(["setting", "value"], _settings(d))
    data_section(page, list(args.data), trajectories, skipped=bool(getattr(args, "skip_checks", False)))
    if d.actuator is not None:
        page.section("Actuator read from the encoders")
        page.paragraph("Before any identification, the actuator law was read from the commands and the encoder "
                       "readings alone (physics.actuator_readings), and compared with the motor model's prediction "
                       "of the same readings (physics.actuator_choice).")
        page.code("\n".join(actuator_text(d)))
    if d.contact is not None:
        page.section("Contact read from the flops")
        page.paragraph("The heights of the nodes touching the floor, against their rods' tilt, tell the end caps' "
                       "shape and, for flat ends, the observations' offset (physics.contact_law).")
        page.code(d.contact.text())
    if d.mismatch is not None:
        page.section("Engine mismatch")
        kept = ", ".join(e.name for e in d.mismatch.effects)
        ratios = d.mismatch.ratios()
        page.paragraph((f"The mismatch stage added {kept} to the T6" if kept else "The mismatch stage kept no "
                        "component change") + f": held-out one-step error ×{ratios['one_step']:.2f}, open-loop "
                       f"drift ×{ratios['drift']:.2f} (after / before). The passes below start from this model.")
        page.code(d.mismatch.text())
    if d.measured:
        page.section("Measured at rest or read from the flops")
        sizes = "; ".join(f"{e.name} (" + ", ".join(f"{q.name} = {q.nominal:.4g} {q.unit}" for q in e.parameters())
                          + ")" for e in d.measured)
        page.paragraph("The data show these effects directly, so they joined the model before the first "
                       f"identification, their parameters kept near the measurement: {sizes}.")
    page.section("Passes")
    for k, p in enumerate(d.passes, 1):
        _pass(page, k, p, d)
    if d.belief is not None:
        page.section("Parameters of the first identification")
        first = d.passes[0]
        theta = np.asarray(first.theta[:d.belief.space.dim], dtype=float)
        page.paragraph("The T6's parameters identified on the fit trajectories; the re-tuned θ̃ is the model "
                       "criticism started from on pass 1.", kind="note")
        parameter_table(page, d.belief, best=theta, best_label="re-tuned θ̃")
    page.details("report.txt", diagnosis_text(d))
    page.section("Figures")
    for name, caption in _FIGURES:
        page.figure(out / name, caption)
    reproduce_section(page, command, resume="The identifications journal their evaluations in the output folder "
                      "(identify_pass*.sqlite): re-running the same command there replays them. For a fresh run, "
                      "give a new --out.",
                      python=f"import json\nrecord = json.loads(open({str(out / 'diagnosis.json')!r}).read())\n"
                             "record['passes'][0]['criticism']['ranking']")
    return page.write(out / "report.html")
