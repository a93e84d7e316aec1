"""Tables and figure of benchmarks/paper.py from its JSON rows (one per problem, seed and method).

A *run* below is one (truth, noise level, seed): runs with other seeds of the same truth count
apart, as their noise and search draws differ.

* held-out E at the best-so-far θ after n evaluations and after t seconds, per sensor-noise level:
  mean ± std over problems of log10 E, and the mean rank of each method (1 = lowest held-out
  error on that problem; tied methods share the mean of their ranks);
* paired against one method (``REFERENCE``, the project's best): per budget and other method, the
  mean difference of log10 held-out E over the runs both made, its standard error
  (std / sqrt(n)), and on how many runs the reference was lower, tied (|difference| < ``TIE``)
  or higher; a difference within two standard errors is not a difference the runs can show;
* parameter error |θ̂ - θ*| / θ* in % of the final best θ, mean ± std over problems (the paper's Table I);
* the posterior's verdicts (methods that return a belief): parameters flagged identified, how many of
  them lie within 1 % of the truth (posterior mean), and how often the 90 % interval holds the truth.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import rankdata


def _rows(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _problem(row: dict[str, Any]) -> tuple:
    return (row["truth_kind"], row["truth_index"], row["noise"], row["seed"])


def _at_evaluations(row: dict[str, Any], n: int) -> float:
    held = row["heldout"]
    return float(held[min(n, len(held)) - 1]) if held else float("nan")


def _at_seconds(row: dict[str, Any], t: float) -> float:
    done = [k for k, s in enumerate(row["seconds"]) if s <= t]
    return float(row["heldout"][done[-1]]) if done else float("nan")


def _table(rows: list[dict[str, Any]], methods: list[str], points: list[float], at: Any, label: str) -> None:
    problems = sorted({_problem(r) for r in rows})
    by = {(r["method"], _problem(r)): r for r in rows}
    print(f"\nheld-out E at the best θ so far, by {label}: mean ± std of log10 E over {len(problems)} runs "
          f"(mean rank, 1 = best)")
    print("| method | " + " | ".join(f"{p:g}" for p in points) + " |")
    print("|---|" + "---|" * len(points))
    ranks = {m: {p: [] for p in points} for m in methods}
    for p in points:
        for prob in problems:
            values = {m: at(by[(m, prob)], p) for m in methods if (m, prob) in by}
            finite = {m: v for m, v in values.items() if np.isfinite(v)}
            for m, rank in zip(finite, rankdata(list(finite.values()), method="average")):
                ranks[m][p].append(float(rank))
    for m in methods:
        cells = []
        for p in points:
            logs = np.log10([at(by[(m, prob)], p) for prob in problems if (m, prob) in by])
            logs = logs[np.isfinite(logs)]
            cells.append(f"{logs.mean():.2f} ± {logs.std():.2f} ({np.mean(ranks[m][p]):.1f})" if len(logs) else "—")
        print(f"| {m} | " + " | ".join(cells) + " |")


#: the method the paired table compares every other one against, and the |Δ log10 E| counted as a tie
REFERENCE, TIE = "ae-cf-bo-gn", 0.005


def _paired(rows: list[dict[str, Any]], methods: list[str], points: list[float]) -> None:
    """Per budget n and method m: Δ = log10 E_REFERENCE(n) - log10 E_m(n) over shared runs,
    printed as mean ± std/sqrt(k) [lower/tied/higher] (negative: the reference is lower)."""
    by = {(r["method"], _problem(r)): r for r in rows}
    problems = sorted({_problem(r) for r in rows if r["method"] == REFERENCE})
    others = [m for m in methods if m != REFERENCE]
    if not problems or not others:
        return
    print(f"\n{REFERENCE} against each method, by evaluations: mean Δ log10 E ± standard error "
          f"[{REFERENCE} lower / tied within {TIE} / higher]")
    print("| method | " + " | ".join(f"{p:g}" for p in points) + " |")
    print("|---|" + "---|" * len(points))
    for m in others:
        shared = [prob for prob in problems if (m, prob) in by]
        cells = []
        for p in points:
            d = np.array([np.log10(_at_evaluations(by[(REFERENCE, prob)], p))
                          - np.log10(_at_evaluations(by[(m, prob)], p)) for prob in shared])
            d = d[np.isfinite(d)]
            if not len(d):
                cells.append("—")
                continue
            se = d.std(ddof=1) / np.sqrt(len(d)) if len(d) > 1 else float("nan")
            cells.append(f"{d.mean():+.2f} ± {se:.2f} [{int((d < -TIE).sum())}/{int((abs(d) <= TIE).sum())}/"
                         f"{int((d > TIE).sum())}]")
        print(f"| {m} | " + " | ".join(cells) + " |")


def _facts(rows: list[dict[str, Any]], methods: list[str]) -> None:
    """Per noise level the mean log10 held-out E at the truth; per method the median wall time of a
    run; and on how many runs ae-cf-bo and bo-15 end at the same best θ."""
    print()
    for noise in sorted({r["noise"] for r in rows}):
        truth = {_problem(r): r["heldout_truth"] for r in rows if r["noise"] == noise and "heldout_truth" in r}
        if truth:
            print(f"noise {noise:g} m: held-out E at the truth, mean log10 {np.mean(np.log10(list(truth.values()))):.2f}")
    print("median wall time per run: " + ", ".join(
        f"{m} {np.median([r['wall'] for r in rows if r['method'] == m]):.0f} s" for m in methods))
    by = {(r["method"], _problem(r)): r for r in rows}
    pairs = [(by[("ae-cf-bo", p)], by[("bo-15", p)]) for m, p in by if m == "ae-cf-bo" and ("bo-15", p) in by]
    if pairs:
        same = sum(np.allclose(a["best_theta"], b["best_theta"]) for a, b in pairs)
        print(f"ae-cf-bo and bo-15 end at the same best θ on {same} of {len(pairs)} runs")


def _parameter_table(rows: list[dict[str, Any]], methods: list[str]) -> None:
    print("\nparameter error of the final best θ in %, mean ± std over problems")
    print("| parameter | " + " | ".join(methods) + " |")
    print("|---|" + "---|" * len(methods))
    for j, name in enumerate(rows[0]["names"]):
        cells = []
        for m in methods:
            errs = np.array([r["param_error_pct"][j] for r in rows if r["method"] == m])
            cells.append(f"{errs.mean():.2f} ± {errs.std():.2f}" if len(errs) else "—")
        print(f"| {name} | " + " | ".join(cells) + " |")


def _verdict_table(rows: list[dict[str, Any]], methods: list[str]) -> None:
    """Per belief method: parameters flagged identified, of those within 1 % of the truth (posterior
    mean), and per verdict and sensor-noise level how many 90 % intervals hold the truth; then every
    identified interval that misses it, and rows a later verdict rule would change (``_stale``)."""
    print("\nposterior verdicts (belief methods): flagged identified, of those within 1 % of the truth; "
          "90 % intervals holding the truth, per verdict, noise 0 m / 0.001 m")
    print("| method | identified | within 1 % | identified: holds truth | weakly identified: holds truth | "
          "not identified: holds truth |")
    print("|---|---|---|---|---|---|")
    misses = []
    for m in methods:
        sel = [r for r in rows if r["method"] == m and "verdict" in r]
        if not sel:
            continue
        flagged = within = 0
        held = {(v, n): [0, 0] for v in ("identified", "weakly identified", "not identified") for n in (0.0, 0.001)}
        for r in sel:
            truth, mean = np.array(r["truth"]), np.array(r["mean"])
            lo, hi = np.array(r["lower"]), np.array(r["upper"])
            ident = np.array([v == "identified" for v in r["verdict"]])
            flagged += int(ident.sum())
            within += int((ident & (np.abs(mean - truth) <= 0.01 * np.abs(truth))).sum())
            for j, verdict in enumerate(r["verdict"]):
                inside = bool(lo[j] <= truth[j] <= hi[j])
                cell = held.setdefault((verdict, r["noise"]), [0, 0])
                cell[0], cell[1] = cell[0] + inside, cell[1] + 1
                if verdict == "identified" and not inside:
                    misses.append((m, r, j))
        cells = [" / ".join(f"{held[(v, n)][0]}/{held[(v, n)][1]}" for n in (0.0, 0.001))
                 for v in ("identified", "weakly identified", "not identified")]
        print(f"| {m} | {flagged} | {within} | " + " | ".join(cells) + " |")
    for m, r, j in misses:
        truth, lo, hi = r["truth"][j], r["lower"][j], r["upper"][j]
        print(f"identified interval missing the truth: {m}, {r['truth_kind']}{r['truth_index']}, noise "
              f"{r['noise']:g}, seed {r['seed']}: {r['names'][j]} [{lo:.5g}, {hi:.5g}], truth {truth:.5g} "
              f"({min(abs(truth - lo), abs(truth - hi)) / (hi - lo):.3f} interval widths outside), best θ "
              f"{r['param_error_pct'][j]:.2f} % off, mean {100 * abs(r['mean'][j] - truth) / abs(truth):.2f} % off")
    print(f"rows whose stored local fit removes more than half of E at θ′ outside a flagged interval (verdict rule "
          f"5a withdraws those verdicts): {_stale(rows)}")


def _stale(rows: list[dict[str, Any]]) -> int:
    """Rows whose stored ``local_fit`` (θ′, E(θ′), E(θ̂)) removes more than ``refit_fraction`` of E
    with θ′ outside the interval of a parameter not marked "not identified": 0 when every row's
    verdicts are those of the current local refit rule."""
    from belief.verdicts import VerdictConfig

    fraction, count = VerdictConfig().refit_fraction, 0
    for r in rows:
        fit = r.get("local_fit") or {}
        if "theta" not in fit or fit["error"] >= (1 - fraction) * fit["start_error"]:
            continue
        count += any(v != "not identified" and not (r["lower"][j] <= fit["theta"][j] <= r["upper"][j])
                     for j, v in enumerate(r["verdict"]))
    return count


#: line colours by method order: matplotlib's ten defaults, then black and dark red
PALETTE = (*(f"C{k}" for k in range(10)), "black", "darkred")
#: methods drawn dashed: the peers a user would pick instead of the project's methods
PEERS = ("cma-es", "botorch")


def _figure(rows: list[dict[str, Any]], methods: list[str], path: Path) -> None:
    """Held-out error against evaluations and wall time, one row of panels per sensor-noise level."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    budget = max(len(r["heldout"]) for r in rows)
    t_max = max(max(r["seconds"]) for r in rows if r["seconds"])
    grids = (np.arange(1, budget + 1), np.linspace(t_max / 50, t_max, 50))
    noises = sorted({r["noise"] for r in rows})
    fig, axes = plt.subplots(len(noises), 2, figsize=(11, 3.8 * len(noises)), squeeze=False)
    for row_axes, noise in zip(axes, noises):
        same = [r for r in rows if r["noise"] == noise]
        for ax, grid, at, xlabel in zip(row_axes, grids, (_at_evaluations, _at_seconds),
                                        ("evaluations", "wall time [s]")):
            for k, m in enumerate(methods):
                sel = [r for r in same if r["method"] == m]
                if not sel:
                    continue
                logs = np.array([[np.log10(at(r, p)) for p in grid] for r in sel])
                mean, std = np.nanmean(logs, axis=0), np.nanstd(logs, axis=0)
                color = PALETTE[k % len(PALETTE)]
                ax.plot(grid, mean, label=m, color=color, linestyle="--" if m in PEERS else "-",
                        linewidth=2.2 if m == REFERENCE else 1.3)
                ax.fill_between(grid, mean - std, mean + std, alpha=0.08, color=color)
            ax.set_xlabel(xlabel)
            ax.set_ylabel("log10 held-out E, best θ so far")
        row_axes[0].set_title(f"sensor noise {noise * 1000:g} mm: mean ± std over "
                              f"{len({_problem(r) for r in same})} runs (truth, seed)")
    axes[0][1].legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def summarize(path: Path, *, figure: Path | None = None) -> None:
    """Print the tables of the rows in ``path`` and draw the figure to ``figure``."""
    rows = _rows(path)
    if not rows:
        print(f"no rows in {path}")
        return
    seen = [r["method"] for r in rows]
    methods = sorted(set(seen), key=seen.index)
    budget = max(len(r["heldout"]) for r in rows)
    points = sorted({p for p in (5, 10, 20, 30, 45, 60, 100) if p <= budget} | {budget})
    t_max = max(max(r["seconds"]) for r in rows if r["seconds"])
    for noise in sorted({r["noise"] for r in rows}):
        same = [r for r in rows if r["noise"] == noise]
        print(f"\n## sensor noise {noise:g} m")
        _table(same, methods, points, _at_evaluations, "evaluations")
        _table(same, methods, [round(t_max * f, 1) for f in (0.1, 0.25, 0.5, 1.0)], _at_seconds, "seconds")
        _paired(same, methods, points)
    _facts(rows, methods)
    _parameter_table(rows, methods)
    _verdict_table(rows, methods)
    if figure is not None:
        _figure(rows, methods, figure)
        print(f"\nwrote {figure}")
