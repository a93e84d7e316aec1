"""Verdicts per parameter: narrow is not enough; P must be verified, supported and consistent."""
from __future__ import annotations

import re

import numpy as np
import pytest
import xarray as xr

from belief.bounds import AtBound
from belief.errors import BeliefError
from belief.grid import Grid
from belief.posterior import PosteriorConfig, marginals, posterior_from_surrogate
from belief.surrogate import GPSurrogate
from belief.verdicts import (RULES, VerdictConfig, because, budget_warning, decide, default_verdicts, loglik_sd,
                             plain_reason, refit_conflicts, rule_of, segment_conflicts, verified_mass)
from embeddings import Identity
from physics.parameters import Parameter, ParameterSpace


def _space(D: int = 2) -> ParameterSpace:
    return ParameterSpace(tuple(Parameter(f"x{i}", "1", 0.5, 0.0, 1.0, minimum=-1.0) for i in range(D)))


def test_gp_lower_tail_on_unevaluated_cells_is_not_identified() -> None:
    """The failure of the issue: evaluations near x0 = 0.2, a sharp σ², and P piled on x0 > 0.5
    (cells nobody evaluated, where the GP's lower tail wins). The old flag says identified; the
    unfloored likelihood (floor="zero") contradicts the evaluations, and the verdict says so."""
    space = _space()
    dec = Identity(space)
    grid = Grid.for_decoder(dec, points_per_dim=41)
    rng = np.random.default_rng(0)
    Z = np.column_stack([rng.uniform(0, 0.35, 10), rng.uniform(0, 1, 10)])
    E = 1.0 + (Z[:, 0] - 0.2) ** 2 + 0.1 * (Z[:, 1] - 0.5) ** 2
    gp = GPSurrogate(grid.bounds).fit(Z, E)
    pred = gp.predict(grid.points)
    noise_var = 1e-4
    best = Z[np.argmin(E)]
    P = posterior_from_surrogate(gp, grid, config=PosteriorConfig(floor="zero"), noise_var=noise_var, prediction=pred)
    marg = marginals(P, dec.decode(grid.points), space)
    x0 = marg.sel(parameter="x0")
    assert bool(x0["identified"]) and float(x0["lower"]) > 0.4      # the old rule: sharp, and wrong
    vmass = verified_mass(P.values.ravel(), loglik_sd(*pred, shift=gp.shift_, noise_var=noise_var), max_sd=1.0)
    assert vmass < 0.01
    verdicts, reasons = decide(marg, best_theta=best, verified=vmass)
    assert verdicts[0] == "not identified"
    assert "contradicts its evaluations" in reasons[0] and "nobody evaluated" in reasons[0]
    # the evaluated floor: no cell outweighs the best evaluation, and P's interval holds it
    P = posterior_from_surrogate(gp, grid, config=PosteriorConfig(), noise_var=noise_var, prediction=pred)
    marg = marginals(P, dec.decode(grid.points), space)
    assert float(marg["lower"][0]) <= best[0] <= float(marg["upper"][0])
    assert decide(marg, best_theta=best, verified=vmass)[0][0] == "not identified"   # 10 evaluations: too few


def _marg(mean, std, lower, upper, prior_std=0.29) -> xr.Dataset:
    n = len(mean)
    dims = ("parameter",)
    return xr.Dataset({"mean": (dims, np.asarray(mean, float)), "std": (dims, np.asarray(std, float)),
                       "lower": (dims, np.asarray(lower, float)), "upper": (dims, np.asarray(upper, float)),
                       "prior_std": (dims, np.full(n, prior_std))},
                      coords={"parameter": [f"x{i}" for i in range(n)]})


def test_decide_follows_the_four_rules() -> None:
    m = _marg(mean=[0.5, 0.5, 0.5, 0.5], std=[0.01, 0.2, 0.28, 0.01],
              lower=[0.48, 0.2, 0.05, 0.48], upper=[0.52, 0.8, 0.95, 0.52])
    v, why = decide(m, best_theta=[0.5, 0.5, 0.5, 0.9], verified=0.9)
    assert v == ["identified", "weakly identified", "not identified", "not identified"]
    assert "outside the interval" in why[3] and "contradicts its evaluations" in why[3]
    v, why = decide(m, best_theta=[0.5, 0.9, 0.5, 0.5], verified=0.9)     # a weak interval must hold it too
    assert v[:2] == ["identified", "not identified"] and "outside the interval" in why[1]
    v, why = decide(m, best_theta=[0.5, 0.5, 0.5, 0.5], verified=0.2)
    assert v[0] == "weakly identified" and "20%" in why[0]
    v, why = decide(m, best_theta=[0.5, 0.5, 0.5, 0.5], verified=0.9, conflicts={"x0": "moves"})
    assert v[0] == "not identified" and why[0] == "moves"
    with pytest.raises(BeliefError, match="best_theta must have shape"):
        decide(m, best_theta=[0.5], verified=1.0)


def test_every_reason_names_the_rule_that_decided_it() -> None:
    """Each verdict's reason starts with its rule's name, in the precedence of the module docstring."""
    m = _marg(mean=[0.5, 0.5, 0.5, 0.5], std=[0.01, 0.2, 0.28, 0.01],
              lower=[0.48, 0.2, 0.05, 0.48], upper=[0.52, 0.8, 0.95, 0.52])
    rules = [rule_of(r) for r in decide(m, best_theta=[0.5, 0.5, 0.5, 0.9], verified=0.9)[1]]
    assert rules == ["narrowing", "narrowing", "narrowing", "evaluated support"]
    assert rule_of(decide(m, best_theta=[0.5] * 4, verified=0.2)[1][0]) == "verified mass"
    local = decide(m, best_theta=[0.5] * 4, verified=0.9, local_ratio=[0.9, 0.0, 0.0, 0.0])
    assert local[0][0] == "not identified" and rule_of(local[1][0]) == "local width"
    pinned = decide(m, best_theta=[0.5] * 4, verified=0.9, conflicts={"x3": because("at bound", "pinned")})
    assert rule_of(pinned[1][3]) == "at bound" and pinned[0][3] == "not identified"
    m["reach"] = ("parameter", np.array([0.1, 1.0, 1.0, 1.0]))
    assert rule_of(decide(m, best_theta=[0.5] * 4, verified=0.9, conflicts={"x0": "moves"})[1][0]) == "reach"
    assert rule_of("moves") == "" and rule_of("narrowing") == "" and set(RULES) >= set(rules)
    with pytest.raises(BeliefError, match="unknown verdict rule"):
        because("rule 5a", "numbered rules are gone")


def test_segment_conflicts_need_two_narrow_disjoint_intervals() -> None:
    a = _marg(mean=[0.3, 0.3, 0.3], std=[0.01, 0.01, 0.2], lower=[0.28, 0.28, 0.0], upper=[0.32, 0.32, 0.7])
    b = _marg(mean=[0.6, 0.31, 0.6], std=[0.01, 0.01, 0.01], lower=[0.58, 0.29, 0.58], upper=[0.62, 0.33, 0.62])
    out = segment_conflicts({"w0": a, "w1": b}, identified_ratio=0.5)
    assert list(out) == ["x0"]                    # x1 overlaps; x2 is not narrow in w0
    assert "w0" in out["x0"] and "w1" in out["x0"]


def test_budget_warning_names_the_numbers() -> None:
    assert budget_warning(150, 15, per_dim=10) == ""
    msg = budget_warning(40, 15, per_dim=10)
    assert "40" in msg and "15-dimensional" in msg and "150" in msg


def test_verdict_config_is_validated() -> None:
    with pytest.raises(BeliefError, match="identified_ratio <= weak_ratio"):
        VerdictConfig(identified_ratio=0.9, weak_ratio=0.5)
    with pytest.raises(BeliefError, match="min_verified_mass"):
        VerdictConfig(min_verified_mass=1.5)


def test_a_parameter_the_decoder_barely_varies_is_not_identified() -> None:
    """Rule 0: a narrow P over a decoder's narrow image says nothing about values it never tried."""
    m = _marg(mean=[0.5, 0.5], std=[0.01, 0.01], lower=[0.48, 0.48], upper=[0.52, 0.52]).assign(
        reach=("parameter", [1.0, 0.2]))
    v, why = decide(m, best_theta=[0.5, 0.5], verified=0.9)
    assert v == ["identified", "not identified"] and "varied it over only 20%" in why[1]
    with pytest.raises(BeliefError, match="min_reach"):
        VerdictConfig(min_reach=1.5)


def test_marginals_report_the_reach_of_the_decoder() -> None:
    space = ParameterSpace((Parameter("a", "1", 1.0, 0.5, 2.5, ""), Parameter("b", "1", 1.0, 0.5, 2.5, "")))
    theta = np.column_stack([np.linspace(0.5, 2.5, 101), np.linspace(0.9, 1.1, 101)])   # b spans 10 % of its box
    P = xr.DataArray(np.full(101, 1 / 101), dims=("z0",))
    reach = marginals(P, theta, space)["reach"].values
    assert abs(reach[0] - 1.0) < 0.05 and abs(reach[1] - 0.1) < 0.01


def test_a_significantly_better_local_fit_outside_the_interval_is_a_conflict() -> None:
    """Rule 5a: θ′ beats θ̂ by 5 nats; x0's interval excludes θ′_0, x1's contains θ′_1."""
    m = _marg(mean=[0.5, 0.5], std=[0.01, 0.01], lower=[0.48, 0.48], upper=[0.52, 0.52])
    out = refit_conflicts(m, [0.6, 0.5], error=1.0, start_error=1.1, noise_var=0.01, nats=3.0)
    assert list(out) == ["x0"] and "more than the noise explains" in out["x0"] and "0.6" in out["x0"]
    assert refit_conflicts(m, [0.6, 0.5], error=1.0, start_error=1.04, noise_var=0.01, nats=3.0) == {}   # 2 nats
    assert list(refit_conflicts(m, [0.6, 0.5], error=1.0, start_error=1.1, noise_var=None, nats=3.0)) == ["x0"]
    assert refit_conflicts(m, [0.6, 0.5], error=1.0, start_error=1.005, noise_var=None, nats=3.0) == {}
    v, why = decide(m, best_theta=[0.5, 0.5], verified=0.9, conflicts=out)
    assert v == ["not identified", "identified"] and "a local fit from the best evaluation" in why[0]
    with pytest.raises(BeliefError, match="refit_nats"):
        VerdictConfig(refit_nats=0.0)


def test_a_local_step_that_halves_e_is_a_conflict_whatever_the_estimated_noise() -> None:
    """Rule 5a: σ² estimated from the residuals at θ̂ (E(θ̂)/σ² = 5) caps any gain at 2.5 nats, so
    a step that removes 73 % of E counts by its share; one that removes 40 % does not."""
    m = _marg(mean=[0.5, 0.5], std=[0.01, 0.01], lower=[0.48, 0.48], upper=[0.52, 0.52])
    out = refit_conflicts(m, [0.6, 0.5], error=0.27, start_error=1.0, noise_var=0.2, nats=3.0)
    assert list(out) == ["x0"] and "73% lower" in out["x0"]
    assert refit_conflicts(m, [0.6, 0.5], error=0.6, start_error=1.0, noise_var=0.2, nats=3.0) == {}
    assert refit_conflicts(m, [0.6, 0.5], error=0.6, start_error=1.0, noise_var=0.2, nats=3.0, fraction=0.3) != {}
    with pytest.raises(BeliefError, match="refit_fraction"):
        VerdictConfig(refit_fraction=1.0)


def test_the_local_ratio_over_all_parameters_caps_the_narrowing() -> None:
    """Rule 5b: P narrow (4 % of the prior) but the full-space local std is 60 % or 90 % of the box's."""
    m = _marg(mean=[0.5, 0.5, 0.5], std=[0.01, 0.01, 0.01], lower=[0.48, 0.48, 0.48], upper=[0.52, 0.52, 0.52])
    v, why = decide(m, best_theta=[0.5, 0.5, 0.5], verified=0.9, local_ratio=[0.01, 0.6, 0.9])
    assert v == ["identified", "weakly identified", "not identified"]
    assert "a local fit over all parameters" in why[1] and "local fit" not in why[0]


#: words of the rules' arithmetic that a user reading a reason cannot know
_JARGON = ("std/prior_std", "prior_std", "identified_ratio", "weak_ratio", "P's", "GP", "nats", "E from")


def _every_kind_of_reason() -> list[str]:
    """One reason of each rule and verdict decide and its helpers give."""
    m = _marg(mean=[0.5, 0.5, 0.5, 0.5], std=[0.01, 0.2, 0.28, 0.01],
              lower=[0.48, 0.2, 0.05, 0.48], upper=[0.52, 0.8, 0.95, 0.52])
    out = decide(m, best_theta=[0.5, 0.5, 0.5, 0.9], verified=0.9)[1]
    out += decide(m, best_theta=[0.5] * 4, verified=0.2)[1]
    out += decide(m, best_theta=[0.5] * 4, verified=0.9, local_ratio=[177.51, 0.6, 0.0, 0.0])[1]
    out += decide(m, best_theta=[0.5] * 4, verified=0.9, local_ratio=[177.51, 0.0, 0.0, 0.0], reduced=True)[1][:1]
    out += default_verdicts(m.assign(prior_std=("parameter", [0.29, 0.29, 0.0, 0.29]),
                                     reach=("parameter", [1.0, 1.0, 1.0, 0.2])))[1]
    out += default_verdicts(m.assign(std=("parameter", [0.01, 0.2, 0.5, 0.01])))[1]
    out += list(segment_conflicts({"t0/w0": _marg([0.3], [0.01], [0.28], [0.32]),
                                   "t0/w1": _marg([0.6], [0.01], [0.58], [0.62])}, identified_ratio=0.5).values())
    out += list(refit_conflicts(m, [0.6, 0.5, 0.5, 0.5], error=0.27, start_error=1.0, noise_var=0.2,
                                nats=3.0).values())
    out.append(because("at bound", AtBound("x0", "1", "upper", 1.0, 0.999, 0.5, "local fit").reason()))
    return out


def test_a_user_reads_plain_words_and_the_rule_stays_in_the_api() -> None:
    """Every reason keeps its rule for code (rule_of), and what a user reads (plain_reason) names no
    rule and none of the rules' arithmetic, nor a share of the prior above 100 %."""
    reasons = _every_kind_of_reason()
    assert {rule_of(r) for r in reasons} == set(RULES) - {"structure"}
    for reason in reasons:
        words = plain_reason(reason)
        assert words and reason.endswith(words), reason
        assert not [rule for rule in RULES if rule in words.lower()], words
        assert not [term for term in _JARGON if term in words], words
        assert not [p for p in re.findall(r"(\d+)%", words) if int(p) > 100], words
    assert plain_reason("P rests on 3 effective cells") == "P rests on 3 effective cells"     # names no rule


def test_only_a_decoder_that_made_the_belief_is_blamed_for_a_trade_off() -> None:
    """The user's case: a full-space search whose local fit leaves a parameter 17751 % of its box's
    spread. The reason says the box's spread is exceeded and that other parameters make up for it;
    the decoder is named only when a lower-dimensional one made P."""
    m = _marg(mean=[0.5], std=[0.01], lower=[0.48], upper=[0.52])
    full = plain_reason(decide(m, best_theta=[0.5], verified=0.9, local_ratio=[177.51])[1][0])
    assert "wider than its box's spread" in full and "other parameters can make up for a change in it" in full
    assert "decoder" not in full and "17751" not in full
    latent = plain_reason(decide(m, best_theta=[0.5], verified=0.9, local_ratio=[177.51], reduced=True)[1][0])
    assert "decoder held those fixed" in latent
