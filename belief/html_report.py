"""Self-contained HTML reports, to hand to a colleague: one file, figures embedded as base64 PNG
data URIs, inline CSS, nothing fetched from elsewhere (standard library only: html, base64).

- :class:`Page`: a generic page builder (sections, paragraphs, tables, embedded figures, code);
- :func:`plain_verdict`: a parameter's verdict in plain words, from the Belief's numbers (interval
  against the prior range, bounds, the best evaluation, the local fit), next to the verdict's reason;
- :func:`parameter_table`, :func:`data_section`, :func:`reproduce_section`, :func:`command_line`:
  the pieces both reports share (criticism.html_report builds the diagnose report from them);
- :func:`write_identify_report`: ``DIR/report.html`` of ``tensegrid identify``: what was run (the
  command with every option, the preset's stages, the settings, the data files with their checks,
  physics.checks), the results, the figures and how to reproduce the run.
"""
from __future__ import annotations

import argparse
import base64
import hashlib
import html
import json
import os
import platform
import shlex
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from belief.bounds import AT_BOUND_TOLERANCE, inadequacy_text
from belief.verdicts import plain_reason, rule_of

if TYPE_CHECKING:
    from belief.belief import Belief
    from belief.result import IdentificationResult

__all__ = ["Page", "plain_verdict", "parameter_table", "data_section", "reproduce_section", "command_line",
           "write_identify_report"]

_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;
color:#1f2328;line-height:1.45}
h1{font-size:1.6em;border-bottom:2px solid #d0d7de;padding-bottom:.2em}h2{margin-top:1.8em;font-size:1.3em}
h3{font-size:1.05em}nav a{margin-right:1em}table{border-collapse:collapse;margin:.6em 0;font-size:.9em}
th,td{border:1px solid #d0d7de;padding:.25em .5em;text-align:left;vertical-align:top}th{background:#f6f8fa}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
tr.identified td:first-child{border-left:4px solid #1a7f37}tr.weakly td:first-child{border-left:4px solid #bf8700}
tr.not td:first-child{border-left:4px solid #8c959f}tr.error td{background:#ffebe9}tr.warning td{background:#fff8c5}
pre{background:#f6f8fa;padding:.7em;overflow-x:auto;font-size:.85em;white-space:pre-wrap}
p.warning{background:#fff8c5;border-left:4px solid #bf8700;padding:.4em .7em}
p.note{color:#57606a;font-size:.92em}figure{margin:1em 0}figure img{max-width:100%;border:1px solid #d0d7de}
figcaption{color:#57606a;font-size:.9em}
"""
#: P's std over the prior's at or above which the data "barely" narrow a parameter (plain words only)
_BARELY = 0.8
#: the verdict rules named at the head of a reason (belief.verdicts) -> the words for a parameter they rejected
_RULE_WORDS = {
    "reach": "the search explored only a small part of its prior range, so values elsewhere were never tried",
    "segment consistency": "different parts of the data put its best value in different places",
    "local refit": "a local fit from the best evaluation found a better value outside its interval",
    "verified mass": "its interval rests on values the search never evaluated",
    "evaluated support": "the posterior disagrees with the best evaluation, which lies outside its interval",
}


def _text(text: str) -> str:
    """``text`` escaped for HTML with its line breaks kept (a multi-line block such as the model
    inadequacy one would otherwise run together into one line)."""
    return html.escape(text).replace("\n", "<br>\n")


def _num(value: float) -> str:
    """A number for a table: 4 significant digits, '-' for NaN."""
    return "-" if not np.isfinite(value) else f"{value:.4g}"


class Page:
    """An HTML page assembled in order: every text is escaped (its line breaks kept), figures are embedded
    as data URIs, and :meth:`render` adds the inline style sheet and a table of contents of the sections."""

    def __init__(self, title: str) -> None:
        self.title = title
        self._body: list[str] = []
        self._toc: list[tuple[str, str]] = []

    def section(self, title: str) -> None:
        anchor = f"s{len(self._toc) + 1}"
        self._toc.append((anchor, title))
        self._body.append(f'<h2 id="{anchor}">{html.escape(title)}</h2>')

    def subsection(self, title: str) -> None:
        self._body.append(f"<h3>{html.escape(title)}</h3>")

    def paragraph(self, text: str, *, kind: str = "") -> None:
        """A paragraph; ``kind`` "warning" or "note" styles it."""
        cls = f' class="{kind}"' if kind else ""
        self._body.append(f"<p{cls}>{_text(text)}</p>")

    def bullets(self, items: Sequence[str]) -> None:
        self._body.append("<ul>" + "".join(f"<li>{_text(i)}</li>" for i in items) + "</ul>")

    def table(self, header: Sequence[str], rows: Sequence[Sequence[Any]], *,
              classes: Sequence[str] | None = None) -> None:
        """A table; numbers are formatted (4 significant digits) and right-aligned, ``classes`` style rows."""
        out = ["<table><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>"]
        for k, row in enumerate(rows):
            cls = f' class="{classes[k]}"' if classes and classes[k] else ""
            cells = [f'<td class="num">{_num(float(c))}</td>' if isinstance(c, (int, float, np.number))
                     else f"<td>{_text(str(c))}</td>" for c in row]
            out.append(f"<tr{cls}>" + "".join(cells) + "</tr>")
        self._body.append("".join(out) + "</table>")

    def code(self, text: str) -> None:
        self._body.append(f"<pre>{html.escape(text)}</pre>")

    def details(self, summary: str, text: str) -> None:
        """A collapsed block of preformatted text."""
        self._body.append(f"<details><summary>{html.escape(summary)}</summary><pre>{html.escape(text)}</pre></details>")

    def figure(self, png: str | os.PathLike[str] | bytes, caption: str) -> bool:
        """Embed a PNG (a path or its bytes) with a caption; False (nothing added) when the file is missing."""
        if not isinstance(png, bytes):
            if not os.path.isfile(png):
                return False
            png = Path(png).read_bytes()
        data = base64.b64encode(png).decode("ascii")
        self._body.append(f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
                          f"<figcaption>{html.escape(caption)}</figcaption></figure>")
        return True

    def render(self) -> str:
        """The whole document."""
        toc = " ".join(f'<a href="#{a}">{html.escape(t)}</a>' for a, t in self._toc)
        return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{html.escape(self.title)}'
                f"</title><style>{_CSS}</style></head><body><h1>{html.escape(self.title)}</h1><nav>{toc}</nav>\n"
                + "\n".join(self._body) + "\n</body></html>\n")

    def write(self, path: str | os.PathLike[str]) -> Path:
        path = Path(path)
        path.write_text(self.render(), encoding="utf-8")
        return path


def plain_verdict(belief: Belief, j: int, *, marginals: xr.Dataset | None = None,
                  evaluated: np.ndarray | None = None) -> str:
    """Parameter j's verdict in plain words: how much of its prior range the credible interval spans,
    and, when it is not identified, why (a bound, the search's reach, the best evaluation ``evaluated``
    (D,) outside the interval, a trade-off with other parameters, a failed consistency check)."""
    m = belief.marginals() if marginals is None else marginals
    space, verdict = belief.space, belief.verdict[j]
    lo, hi = float(m["lower"].values[j]), float(m["upper"].values[j])
    width = float(space.upper[j] - space.lower[j])
    share = (hi - lo) / width if width > 0 else float("nan")
    prior = float(m["prior_std"].values[j])
    ratio = float(m["std"].values[j]) / prior if prior > 0 else float("inf")
    level = float(m.attrs.get("level", belief.level))
    unit = "" if space.units[j] in ("", "1") else f" {space.units[j]}"          # "1": dimensionless
    interval = f"{level:.0%} interval {lo:.4g} to {hi:.4g}{unit}"
    side = str(m["at_bound"].values[j]) if "at_bound" in m else ""
    if side:
        bound = space.lower[j] if side == "lower" else space.upper[j]
        return (f"The fit presses against the {side} end of its prior range ({bound:.4g}{unit}): the model cannot "
                "fit the data inside the range (an effect it stands in for is missing, or the range is too narrow; "
                "tensegrid diagnose tests which), so this value is the bound, not an estimate.")
    if prior <= 0:
        return "The search never varied this parameter, so the data say nothing about it."
    if verdict == "identified":
        return f"The data pin it down: they narrow it to {share:.0%} of its prior range ({interval})."
    local = np.asarray((belief.attrs.get("local_fit") or {}).get("std", []), dtype=float)
    local_ratio = float(local[j]) / (width / np.sqrt(12.0)) if local.size == space.dim and width > 0 else 0.0
    head = rule_of(belief.reason[j])
    if head in _RULE_WORDS:
        why = _RULE_WORDS[head]
    elif local_ratio >= max(ratio, _BARELY):
        why = ("other parameters can make up for a change in it, so the data do not fix it on its own (a local fit "
               "over all parameters leaves it " + ("less certain than its whole prior range)" if local_ratio >= 1
                                                   else "nearly as uncertain as its prior range)"))
    elif evaluated is not None and not lo <= float(evaluated[j]) <= hi:
        why = _RULE_WORDS["evaluated support"]
    elif ratio >= _BARELY:
        why = "the data barely narrow it"
    else:
        why = "" if verdict == "weakly identified" else "a consistency check failed (see each verdict's reason)"
    if verdict == "weakly identified":
        return (f"The data narrow it to {share:.0%} of its prior range ({interval}), not enough to rely on"
                + (f": {why}." if why else "."))
    return (f"Not determined: {why}; its {level:.0%} interval ({lo:.4g} to {hi:.4g}{unit}) still spans "
            f"{share:.0%} of its prior range.")


def parameter_table(page: Page, belief: Belief, *, best: np.ndarray, best_label: str = "best θ",
                    truth: np.ndarray | None = None, evaluated: np.ndarray | None = None) -> None:
    """The results table (nominal, ``best``, posterior mean, credible interval, truth when known, verdict and
    its plain words, one row per parameter) and each verdict's reason (belief.verdicts.plain_reason) collapsed
    below it."""
    m = belief.marginals()
    space = belief.space
    level = float(m.attrs.get("level", belief.level))
    header = ["parameter", "unit", "nominal", best_label, "posterior mean", f"{level:.0%} interval"]
    header += (["truth"] if truth is not None else []) + ["verdict", "in plain words"]
    rows, classes = [], []
    for j, name in enumerate(space.names):
        lo, hi = float(m["lower"].values[j]), float(m["upper"].values[j])
        row: list[Any] = [name, space.units[j], float(space.nominal[j]), float(best[j]), float(m["mean"].values[j]),
                          f"[{lo:.4g}, {hi:.4g}]"]
        row += [float(truth[j])] if truth is not None else []
        rows.append(row + [belief.verdict[j], plain_verdict(belief, j, marginals=m, evaluated=evaluated)])
        classes.append(belief.verdict[j].split()[0])
    page.table(header, rows, classes=classes)
    page.details("Each verdict's reason, with the numbers of its check",
                 "\n".join(f"{n}: {v}: {plain_reason(r)}" for n, v, r in zip(space.names, belief.verdict, belief.reason,
                                                                               strict=True)))


def _sha256(path: str) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def data_section(page: Page, sources: Sequence[str], datasets: Sequence[xr.Dataset], *, skipped: bool = False,
                 none: str = "No data file.") -> None:
    """Per data file: its path, size and SHA-256, what it holds (physics.trajectory.describe_trajectory) and
    the findings of the data checks (physics.checks, as ``tensegrid check`` prints them, with their fix)."""
    from physics.checks import check_trajectory
    from physics.trajectory import describe_trajectory

    page.section("Data and checks")
    if not sources:
        page.paragraph(none)
        return
    page.paragraph("Each file was checked as `tensegrid check` does (docs/data-format.md) before the run."
                   + (" The run was started with --skip-checks: errors did not stop it." if skipped else ""))
    for src, ds in zip(sources, datasets, strict=True):
        page.subsection(str(src))
        report = check_trajectory(ds, source=str(src))
        size = os.path.getsize(src) if os.path.isfile(src) else None
        facts = [f"path: {os.path.abspath(src)}"]
        facts += [f"size {size} bytes, SHA-256 {_sha256(src)}"] if size is not None else []
        page.bullets(facts + describe_trajectory(ds))
        rows = [[f.severity, f.code, f.message, f.fix] for f in report.findings]
        page.table(["severity", "check", "finding", "fix"], rows, classes=[f.severity for f in report.findings])
        page.paragraph(f"{len(report.errors)} error(s), {len(report.warnings)} warning(s).", kind="note")


def command_line(command: str, args: argparse.Namespace, *, positional: str = "data") -> str:
    """``tensegrid COMMAND`` with the positional files and every option the run used, explicit (options at
    their default included; unset options, false flags and empty lists left out), shell-quoted."""
    parts = ["tensegrid", command, *[str(p) for p in (getattr(args, positional, None) or [])]]
    for key, value in vars(args).items():
        if key in (positional, "command", "func") or callable(value) or value is None or value is False or (
                isinstance(value, (list, tuple)) and not value):
            continue
        flag = "--" + key.replace("_", "-")
        if value is True:
            parts.append(flag)
        elif isinstance(value, (list, tuple)):
            parts += [flag, *[str(v) for v in value]]
        else:
            parts += [flag, str(value)]
    return shlex.join(parts)


def _versions() -> str:
    """Versions of the pieces that make a run reproducible."""
    found = []
    for name in ("tensegrid", "numpy", "dartpy", "torch", "pyro-ppl"):
        try:
            found.append(f"{name} {version(name)}")
        except PackageNotFoundError:
            continue
    return f"Python {platform.python_version()}, " + ", ".join(found)


def reproduce_section(page: Page, command: str, *, resume: str, python: str) -> None:
    """How to run it again: the folder and command, what re-running in the same --out does, how to load the
    result in Python, and the versions."""
    page.section("How to reproduce")
    page.paragraph(f"From the folder {os.getcwd()}:")
    page.code(command)
    page.paragraph(resume)
    page.paragraph("In Python:")
    page.code(python)
    page.paragraph(f"Versions: {_versions()}.", kind="note")


def _settings(result: IdentificationResult, args: argparse.Namespace) -> list[list[Any]]:
    """(setting, value) rows of an identify run."""
    cfg, attrs = result.config, (result.belief.attrs if result.belief is not None else {})
    obj, grid = cfg.get("objective") or {}, cfg.get("grid") or {}
    rows: list[list[Any]] = [
        ["preset", f"{cfg.get('preset', args.preset)}: " + " -> ".join(cfg.get("stages", []))],
        ["evaluations", result.evaluations_text()
                        + (f" (stopped: {cfg['stopped']})" if cfg.get("stopped") else "")],
        ["objective", f"{obj.get('kind', '?')}, loss {obj.get('loss', '-')}, horizon {obj.get('horizon', '-')}"],
        ["segments", ", ".join(attrs.get("segments", [])) or "-"],
        ["decoder / cells", f"{(cfg.get('decoder') or {}).get('kind', '?')} / {grid.get('kind', '?')} "
                            f"({grid.get('n', grid.get('points_per_dim', '?'))})"],
        ["posterior", f"{attrs.get('mode', args.posterior)}, noise rule {attrs.get('noise_rule', '-')}, "
                      f"σ² = {_num(float(attrs.get('noise_var', float('nan'))))}, "
                      f"{float(attrs.get('level', 0.9)):.0%} credible intervals"],
        ["seed", cfg.get("seed", args.seed)],
    ]
    step = cfg.get("local_step")
    if step:
        rows.append(["Gauss-Newton step", f"{step['evaluations']} evaluations of E, E {step['start_error']:.4g} -> "
                                          f"{step['error']:.4g}" + (" (its point is the best θ)" if step["improved"]
                                                                     else " (no lower; the best θ is kept)")])
    return rows


_FIGURES = (
    ("error_vs_evaluations.png", "E of every evaluation and the best so far; the green star is the finishing "
                                 "Gauss-Newton step when the preset has one."),
    ("posterior_marginals.png", "The marginal of P of each parameter against the prior, its credible interval "
                                "shaded (dashed edges), the truth in red when the data carry it."),
    ("pairs.png", "The 2-D marginals of P of the parameters most correlated under P: a tilted ridge means the "
                  "data fix a combination of them, not each one."),
    ("posterior_2d.png", "P over the 2-D grid, the evaluations as dots."),
    ("observed_vs_predicted.png", "The observed centre of mass against free rollouts at the nominal, best and "
                                  "posterior-mean θ. The identification fits predictions restarted from each "
                                  "observed sample, so a free rollout can drift even at the best θ."),
)


def _outcome(page: Page, result: IdentificationResult, belief: Belief) -> None:
    """The verdict counts, the best error with its unit and the warnings of the run."""
    from belief.plots import error_unit

    groups = {v: [n for n, w in zip(belief.space.names, belief.verdict, strict=True) if w == v]
              for v in ("identified", "weakly identified", "not identified")}
    page.paragraph("; ".join(f"{len(n)} {v}" + (f" ({', '.join(n)})" if n and v != "not identified" else "")
                             for v, n in groups.items()) + f" of {belief.space.dim} parameters.")
    unit, meaning = error_unit(result.config)
    page.paragraph(f"Best error E = {result.best_error:.4g} {unit} ({meaning}) after {result.n_evaluations} "
                   "evaluations.")
    block = inadequacy_text(belief.at_bounds, tolerance=belief.attrs.get("bound_tolerance", AT_BOUND_TOLERANCE))
    for warning in (belief.attrs.get("trust"), belief.attrs.get("budget_warning"), block):
        if warning:
            page.paragraph(f"Warning: {warning}", kind="warning")


def write_identify_report(out: str | os.PathLike[str], result: IdentificationResult, args: argparse.Namespace,
                          datasets: Sequence[xr.Dataset], *, truth: np.ndarray | None = None) -> Path:
    """Write ``out/report.html`` of an identify run (module docstring) from the result, the command line's
    ``args`` and the loaded ``datasets`` (``args.data``); the figures already in ``out`` are embedded."""
    if result.belief is None:
        raise ValueError("the identify report needs a result with a belief (a posterior mode).")
    belief, out = result.belief, Path(out)
    page = Page(f"tensegrid identify: {', '.join(os.path.basename(d) for d in args.data) or 'the push toy'}")
    _outcome(page, result, belief)
    page.section("What was run")
    command = command_line("identify", args)
    page.code(command)
    page.table(["setting", "value"], _settings(result, args))
    page.details("the run's configuration (result.nc, config)", json.dumps(result.config, indent=1, default=str))
    data_section(page, list(args.data), datasets, skipped=bool(getattr(args, "skip_checks", False)),
                 none="No data file: the 1-D push toy of physics.push (simulated pushes of a sliding point).")
    page.section("Results")
    h = result.history
    ok = np.flatnonzero(h["status"].values == "ok")
    evaluated = h["theta"].values[ok[np.argmin(h["error"].values[ok])]] if ok.size else None
    parameter_table(page, belief, best=np.asarray(result.best_theta.values, dtype=float), truth=truth,
                    evaluated=evaluated)
    pin = result.identifiability
    if pin is not None:
        page.subsection("What the data pin")
        page.code("\n".join(pin.lines()))
    for key, title in (("actuator", "The actuator read from the encoders"), ("next_recording", "What to record next")):
        record = result.config.get(key)
        if isinstance(record, dict) and record.get("lines"):
            page.subsection(title)
            page.code("\n".join(str(line) for line in record["lines"]))
    page.details("summary.txt", result.summary(truth=truth))
    page.section("Figures")
    for name, caption in _FIGURES:
        page.figure(out / name, caption)
    reproduce_section(page, command, resume="Every evaluation is journalled in the output folder (journal.sqlite): "
                      "re-running the same command there resumes the run and re-evaluates nothing. For a fresh "
                      "run, give a new --out.",
                      python=f"from belief import IdentificationResult\nresult = IdentificationResult.load("
                             f"{str(out / 'result.nc')!r})\nprint(result.summary())\nresult.belief.marginals()")
    return page.write(out / "report.html")
