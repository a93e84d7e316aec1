"""The tables benchmarks/effects.py prints from its rows: per scenario how often the true effect is
ranked first, named and found, how often anything is claimed, the held-out error after / before,
the fitted size against the true one (on the testbed in its own terms, flagged at a bound), the
contests between effects, and one line per row.
"""
from __future__ import annotations

import math

import numpy as np

from criticism.search import CriticismConfig
from physics import ParameterSpace, load_trajectory
from physics.effects import EFFECT_TYPES, effect_from_config

#: Size of each effect in the benchmark (SI): material next to 0.2 mm sensor noise, as the
#: differences between two engines' SUPERballs are (an actuator reaching its target in 0.11 s,
#: caps touching the ground at 31 mm instead of 60 mm).
SIZES = {"ground_slope": {"slope_x": 0.08}, "air_drag": {"drag": 8.0}, "viscous_drag": {"viscous_drag": 4.0},
         "ground_viscosity": {"ground_viscosity": 150.0},
         "cable_hysteresis": {"hysteresis": 0.5}, "nonlinear_stiffness": {"stiffness_quadratic": 3.0},
         "actuator_delay": {"actuator_delay": 0.08}, "rate_limited_actuator": {"actuator_rate": 1.6},
         "sensor_bias": {"sensor_bias_z": 0.02}, "end_cap_radius": {"cap_radius_change": -0.029},
         "point_mass": {"point_mass": 1.5}, "encoder_offset": {"encoder_offset": 0.05}}


#: catalog effects that model the same cause with another law: either counts as the cause ranked first or found
SAME_CAUSE: dict[str, frozenset[str]] = {"air_drag": frozenset({"air_drag", "viscous_drag"}),
                                         "viscous_drag": frozenset({"air_drag", "viscous_drag"})}


def same_cause(effect: str | None, truth: str | None) -> bool:
    """Whether ``effect`` is the true effect ``truth`` or another law of its cause (:data:`SAME_CAUSE`)."""
    return effect is not None and (effect == truth or effect in SAME_CAUSE.get(truth or "", ()))


def _at_bound(effect: str, values: dict[str, float], config: dict | None = None) -> list[str]:
    """The parameters of a fitted catalog effect within 1 % of the box width of a bound: the box of
    the effect as fitted (``config``, Effect.config: a measured slope or bias keeps a box around
    its measurement), of the free effect for rows that do not record it."""
    out = []
    for p in (effect_from_config(config) if config else EFFECT_TYPES[effect]()).parameters():
        v, width = values.get(p.name), p.upper - p.lower
        if v is not None and min(v - p.lower, p.upper - v) <= 0.01 * width:
            out.append(f"{p.name} at its {'lower' if v - p.lower < p.upper - v else 'upper'} bound")
    return out


def catalog_equivalent(effect: str, truth: dict, row: dict | None = None) -> tuple[float, float] | None:
    """The testbed's hidden effect expressed in the law of the catalog effect that models it, as a
    range (low, high) of sizes, where the two laws map onto each other (None elsewhere):

    - cable_hysteresis: the testbed's cables pull k (1 - h_t) while shortening and k while
      lengthening, the catalog's k' while shortening and k' (1 + h) while lengthening. With the
      T6's stiffness free, k' = (1 - h_t) k and h = h_t / (1 - h_t) match both branches (high).
      The T6's box stops at k_lo = 0.9 k, where matching the lengthening branch gives
      h = k / k_lo - 1 (low). The testbed's data sets use the nominal k.
    - air_drag: the testbed's rod ends feel -d v, the catalog's -c |v| v; the c closest in force
      over the speeds s of the rod ends in the row's two fit flops (least squares):
      c = d Σ s³ / Σ s⁴ (low = high).
    - actuator_delay, viscous_drag: the same law in both (delay [s], drag [N s/m]; low = high).
    """
    if effect == "actuator_delay":
        return truth["actuator_delay"], truth["actuator_delay"]
    if effect == "viscous_drag":
        return truth["drag"], truth["drag"]
    if effect == "cable_hysteresis":
        t6 = ParameterSpace.t6()
        k = t6.index("stiffnessActive")
        return float(t6.nominal[k] / t6.lower[k] - 1.0), truth["hysteresis"] / (1.0 - truth["hysteresis"])
    if effect == "air_drag" and row is not None:
        from testbed.datasets import cached_dataset
        files = cached_dataset(row["scenario"], row["seed"], noise=0.0002, version=row.get("flops_version", 1),
                               engine=row.get("engine", "bullet"))
        cubes = quartics = 0.0
        for label in ("flop_0", "flop_1"):
            ds = load_trajectory(files[label])
            x = ds["nodes"].transpose("time", "node", "axis").values
            speed = np.linalg.norm(np.gradient(x, ds["time"].values, axis=0), axis=2)
            cubes, quartics = cubes + np.nansum(speed ** 3), quartics + np.nansum(speed ** 4)
        c = truth["drag"] * cubes / quartics
        return c, c
    return None


def _range_text(equivalent: tuple[float, float]) -> str:
    low, high = equivalent
    return f"{low:.4g}" if low == high else f"{low:.4g} to {high:.4g}"


def testbed_size(effect: str, values: dict[str, float], truth: dict, config: dict | None = None,
                 equivalent: tuple[float, float] | None = None) -> str:
    """The fitted size of a catalog effect next to the testbed's hidden one, in the testbed's terms
    (slope: tilt [deg] and the angle between fitted and true floor normals; marker offset: its z
    [mm]; delay [ms]; others in each one's own unit, with ``equivalent``, the truth in the
    catalog's law, when given: :func:`catalog_equivalent`), flagged at a bound."""
    if effect == "ground_slope":
        from physics.effects.world import slope_normal
        n = slope_normal(values["slope_x"], values["slope_y"])
        a, t = truth["slope_azimuth"], truth["slope"]
        true_n = np.array([-np.sin(t) * np.cos(a), -np.sin(t) * np.sin(a), np.cos(t)])
        text = (f"tilt {np.degrees(np.arccos(n[2])):.2f} deg (true {np.degrees(t):.2f}), normals "
                f"{np.degrees(np.arccos(np.clip(n @ true_n, -1, 1))):.2f} deg apart")
    elif effect == "sensor_bias":
        text = f"z offset {1e3 * values['sensor_bias_z']:.1f} mm (true {1e3 * truth['marker_offset'][2]:.1f})"
    elif effect == "actuator_delay":
        text = f"delay {1e3 * values['actuator_delay']:.0f} ms (true {1e3 * truth['actuator_delay']:.0f})"
    else:
        units = {p.name: p.unit for p in EFFECT_TYPES[effect]().parameters()}
        fitted = ", ".join(f"{k}={v:.4g} {units[k]}" for k, v in values.items())
        own = ", ".join(f"{k}={v}" for k, v in truth.items() if v)
        text = (f"{fitted} (testbed {own} in its own law" + (f"; {_range_text(equivalent)} in the catalog's)"
                if equivalent is not None else ")"))
    return "; ".join([text, *_at_bound(effect, values, config)])


def _sizes(rows: list[dict]) -> None:
    """The sizes of the testbed rows whose true effect is ranked first, and its re-identified
    interval, with whether it holds the truth in the catalog's law (:func:`catalog_equivalent`);
    then the tally: intervals that hold it, and claims ("identified") that miss it."""
    sized = [r for r in rows if r.get("held_out") == "testbed" and r["truth"] and same_cause(r["top"], r["truth"][0])]
    if sized:
        print("\nsizes where the true effect is ranked first (testbed):")
    tally: list[tuple[str, bool]] = []
    for r in sized:
        equivalent = catalog_equivalent(r["top"], r["true_values"], r)
        print(f"{r['scenario']} seed {r['seed']}{' (found)' if r['found'] else ''}: "
              + testbed_size(r["top"], r["top_values"], r["true_values"], r.get("top_config"), equivalent))
        for name, e in (r.get("estimates") or {}).items():
            lower, upper = e.get("lower", float("nan")), e.get("upper", float("nan"))
            holds = None
            if equivalent is not None and name in r["top_values"]:
                holds = bool(lower <= equivalent[1] and equivalent[0] <= upper)
                tally.append((e.get("verdict", ""), holds))
            meets = "" if holds is None else \
                f"; meets the catalog-law truth {_range_text(equivalent)}: {'yes' if holds else 'NO'}"
            print(f"    re-identified {name}: {e['value']:.4g} in [{lower:.4g}, {upper:.4g}] ({e.get('verdict', '')}"
                  f"{', at ' + e['at_bound'] + ' bound' if e.get('at_bound') else ''}){meets}")
    if tally:
        claims = [holds for verdict, holds in tally if verdict == "identified"]
        print(f"intervals that meet the catalog-law truth: {sum(h for _, h in tally)} of {len(tally)}; "
              f"claims (identified) that miss it: {claims.count(False)} of {len(claims)}")


def _searched(row: dict) -> list[str]:
    """The effects a row's search found, in order (those measured at rest left out)."""
    return [f for f in row["found"] if f not in row.get("measured", [])]


def _second_found(row: dict, first: str, second: str) -> bool:
    """Of a mix, whether the smaller effect was found: measured at rest, or found right after the
    larger one (which may itself have been measured at rest and the smaller found on pass 1)."""
    found = row["found"]
    if second in row.get("measured", []):
        return True
    return first in found and second in found and found.index(second) == found.index(first) + 1


def _column_truth(effect: str, row: dict) -> str:
    """The size the table's "criticism fit (true)" column compares with: the own-engine
    scenario's (``SIZES``), or on testbed rows the testbed's truth in the catalog's law ("?"
    where the two laws do not map onto each other)."""
    if row.get("held_out") != "testbed":
        return f"{next(iter(SIZES[effect].values())):.4g}"
    equivalent = catalog_equivalent(effect, row["true_values"], row)
    return "?" if equivalent is None else _range_text(equivalent)


def summarize(rows: list[dict]) -> None:
    """The table of the module docstring, one line per scenario, then :func:`details` and the sizes."""
    print(f"{'scenario':22s} {'seeds':>5} {'top=true':>8} {'named':>5} {'found':>6} {'claimed':>7} {'explained':>9} "
          f"{'after/before (max)':>18} {'criticism fit (true)':>24} {'2nd found':>9}")
    for name in dict.fromkeys(r["scenario"] for r in rows):
        rs = [r for r in rows if r["scenario"] == name]
        if len({r.get("held_out", "heading") for r in rs}) > 1:
            print(f"{name}: rows of both --held-out protocols; summarize one protocol's rows at a time")
        truth = rs[0]["truth"]
        first = rs[0].get("larger", truth[0] if truth else None) if truth and name != "outside" else None
        other = [t for t in truth if t != first]
        top_ok = sum(same_cause(r["top"], first) or first in r.get("measured", []) for r in rs) if first else "-"
        found_ok = (sum(first in r.get("measured", []) or same_cause((_searched(r) or [None])[0], first) for r in rs)
                    if first else "-")
        named = (sum(same_cause(r["top"], first) or first in r.get("alternatives", []) + r.get("measured", [])
                     for r in rs) if first else "-")
        claimed = sum(bool(r["found"]) for r in rs)
        explained = np.median([r["top_explained"] for r in rs if r["top_explained"] is not None])
        ratios = [r["held_after"] / r["held_before"] for r in rs if r["held_after"] is not None]
        ratio = f"{np.median(ratios):.2f} ({max(ratios):.2f})" if ratios else "-"
        est = "-"
        if first and name in SIZES:
            key = next(iter(SIZES[first]))
            vals = [r["top_values"].get(key) for r in rs if r["top"] == first]
            est = f"{np.median(vals):.4g} ({_column_truth(first, rs[0])})" if vals else "-"
        second = sum(_second_found(r, first, other[0]) for r in rs) if len(truth) > 1 else "-"
        print(f"{name:22s} {len(rs):5d} {str(top_ok):>8} {str(named):>5} {str(found_ok):>6} {claimed:7d} {explained:9.1%} "
              f"{ratio:>18} {est:>24} {str(second):>9}")
    details(rows)
    _sizes(rows)
    staged = [r for r in rows if r.get("stage")]
    for r in staged:
        ratios = r["stage"]["ratios"]
        print(f"{r['scenario']} seed {r['seed']}: mismatch stage kept {', '.join(r['stage']['kept']) or 'nothing'}; "
              f"held-out one-step {ratios['one_step']:.2f}x, drift {ratios['drift']:.2f}x")


def _apart(a: dict[str, float], b: dict[str, float], k: int = 3, truth: dict[str, float] | None = None) -> str:
    """The k model parameters on which two joint fits differ most, |a - b| / max(|a|, |b|), as
    "name a/b" (the truth's contender first), with θ* where ``truth`` has it."""
    rel = {n: abs(a[n] - b[n]) / max(abs(a[n]), abs(b[n]), 1e-300) for n in a if n in b}
    return ", ".join(f"{n} {a[n]:.4g}/{b[n]:.4g}" + (f" (θ* {truth[n]:.4g})" if truth and n in truth else "")
                     for n in sorted(rel, key=rel.get, reverse=True)[:k])


def details(rows: list[dict]) -> None:
    """The figures behind the table: the largest after/before ratios, the top evidence where
    nothing should be claimed, and every contest between effects that would each be found
    (margin = evidence of the true effect - that of the best other; which flop favoured it)."""
    ratios = sorted(((r["held_after"] / r["held_before"], r["scenario"], r["seed"]) for r in rows
                     if r.get("held_after") is not None), reverse=True)
    print(f"\nafter/before: {sum(v <= 0.5 for v, _, _ in ratios)} of {len(ratios)} runs at most 0.5; largest: "
          + ", ".join(f"{name} seed {seed} {v:.2f}" for v, name, seed in ratios[:3]))
    for name in ("none", "outside", "nominal"):
        evidence = [r["top_evidence"] for r in rows if r["scenario"] == name]
        if evidence:
            print(f"{name}: top evidence {min(evidence):.1f} to {max(evidence):.1f} over {len(evidence)} runs")
    bars = CriticismConfig()
    failed = [r for r in rows if r.get("replication") and ("refit" in r["replication"]
                                                           or not r["replication"]["replicated"])]
    deciding = [f"{r['scenario']} seed {r['seed']}" for r in failed
                if (r["top_evidence"] or 0) >= bars.min_evidence and (r["top_explained"] or 0) >= bars.min_fraction]
    print(f"replication failed with θ̃ held: {len(failed)} runs; of them passing both bars (where the refit check "
          f"decides): {', '.join(deciding) or 'none'}")
    contests = [r for r in rows if len(r.get("contenders") or {}) > 1 and r["truth"]]
    print(f"\ncontests ({len(contests)} of the {sum('contenders' in r for r in rows)} runs that record contenders)")
    for r in sorted(contests, key=lambda r: (r["scenario"], r["seed"])):
        c, true = r["contenders"], r["truth"][0]
        if true not in c:
            print(f"{r['scenario']} seed {r['seed']}: the true effect is no contender; top {r['top']}")
            continue
        other = max((k for k in c if k != true), key=lambda k: c[k]["evidence"])
        apart = (f"; θ apart most in {_apart(c[true]['theta'], c[other]['theta'], truth=r.get('theta_true'))}"
                 if "theta" in c[true] else "")
        print(f"{r['scenario']} seed {r['seed']}: top {r['top']}, the truth's margin over {other} "
              f"{c[true]['evidence'] - c[other]['evidence']:.1f}; fitted flops favour the truth "
              f"{c[true]['fit_error'] < c[other]['fit_error']}, held-out {c[true]['held_error'] < c[other]['held_error']} "
              f"(E_H {c[true]['held_error']:.4f} against {c[other]['held_error']:.4f}); alternatives "
              f"{r.get('alternatives', [])}{apart}")
    placed = [r for r in rows if r.get("true_configs") and (r.get("top_placements") or 1) > 1
              and r["top"] == r["truth"][0]]
    if placed:
        right = sum(r["top_config"] == r["true_configs"][0] for r in placed)
        print(f"\nplaced effects ranked first: at the true place in {right} of {len(placed)} runs")


def print_rows(rows: list[dict]) -> None:
    """One line per row: data set, seed, effects measured at rest, the top of the ranking, found, and
    the held-out error of the first pass's re-tuned model (E before) and after the found effects;
    the top effect's evidence, explained fraction and replication gains, held and refitted where the
    refit check ran (criticism.replication)."""
    print(f"\n{'scenario':18s} {'seed':>4}  {'measured at rest':18s} {'top':22s} {'E before':>10} {'E after':>10}  "
          f"{'evidence':>8} {'explains':>8}  {'replication':22s} found")
    for r in rows:
        after = f"{r['held_after']:10.4g}" if r.get("held_after") is not None else f"{'-':>10}"
        record = r.get("replication") or {}
        replication = " ".join(f"{g} {v:+.0%}" for g, v in (record.get("gains") or {}).items()) or "-"
        if record.get("refit"):
            replication += " refit " + " ".join(f"{g} {v:+.0%}" for g, v in record["refit"].items())
        print(f"{r['scenario']:18s} {r['seed']:4d}  {', '.join(r.get('measured', [])) or '-':18s} {str(r['top']):22s} "
              f"{r['held_before']:10.4g} {after}  {r['top_evidence'] or math.nan:8.1f} "
              f"{r['top_explained'] or math.nan:8.1%}  {replication:22s} {', '.join(r['found']) or '-'}")
