"""DIR/report.html of ``tensegrid identify`` (belief.html_report) and the figures it embeds (belief.plots,
physics.plotting): self-contained, complete, plain words; readable marginals, the unit of E and the
Gauss-Newton step, the pair plot, and a centre of mass that neither jumps nor warns on NaN samples."""
from __future__ import annotations

import argparse
import base64
import html
import re
import warnings

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr

from belief import Belief, Grid, IdentificationResult, SobolCandidates, at_bounds
from belief.cli import register_identify
from belief.bounds import inadequacy_text
from belief.html_report import Page, command_line, plain_verdict
from belief.plots import correlation, most_correlated, plot_error_trace, plot_marginals, plot_pairs, rollout_note
from belief.verdicts import plain_reason, rule_of
from embeddings import Identity
from physics import ParameterSpace
from physics.plotting import observed_vs_predicted_figure, plot_observed_vs_predicted
from physics.push import push_space

T6 = ParameterSpace.t6()


def _identify(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="tensegrid")
    register_identify(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["identify", *argv, "--no-progress", "--no-next"])
    assert args.func(args) == 0
    return args


@pytest.fixture(scope="module")
def push_run(tmp_path_factory) -> argparse.Namespace:
    """The push toy identified by bo-gn (a BO stage and the Gauss-Newton step), writing its report."""
    out = tmp_path_factory.mktemp("push") / "out"
    return _identify(["--toy", "push", "--preset", "bo-gn", "--budget", "10", "--points-per-dim", "15",
                      "--out", str(out)])


def _self_contained(page: str) -> list[str]:
    """The page's image sources, after checking that nothing is fetched from elsewhere."""
    assert 'src="http' not in page and "href=\"http" not in page and "<link" not in page and "<script" not in page
    sources = re.findall(r'<img[^>]*\ssrc="([^"]+)"', page)
    for src in sources:
        assert src.startswith("data:image/png;base64,"), src[:60]
        assert base64.b64decode(src.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    return sources


def test_identify_writes_a_self_contained_report_with_every_parameter(push_run) -> None:
    out = push_run.out
    page = open(f"{out}/report.html", encoding="utf-8").read()
    sources = _self_contained(page)
    for png in ("error_vs_evaluations.png", "posterior_marginals.png", "pairs.png", "posterior_2d.png"):
        with open(f"{out}/{png}", "rb") as fh:
            assert "data:image/png;base64," + base64.b64encode(fh.read()).decode() in sources, png
    result = IdentificationResult.load(f"{out}/result.nc")
    for name, (verdict, _) in result.belief.verdicts.items():
        assert re.search(rf"<td>{name}</td>.*?<td>{verdict}</td>", page), name
    assert "of its prior range" in page                        # the verdicts in plain words
    for reason in result.belief.reason:                         # each reason's words, its rule left to the API
        assert rule_of(reason) and html.escape(plain_reason(reason)) in page and html.escape(reason) not in page
    assert html.escape(command_line("identify", push_run)) in page and "tensegrid identify --toy push" in page
    assert "Data and checks" in page and "the 1-D push toy" in page
    assert "How to reproduce" in page and "bo over the full space" in page       # the preset's stages


@pytest.mark.slow
def test_identify_report_holds_the_data_files_and_their_checks(tmp_path) -> None:
    from physics import FlopController, save_trajectory, simulate

    path = save_trajectory(simulate(T6.nominal, controller=FlopController(heading=0.0), duration=0.4),
                           tmp_path / "flop.nc")
    # the T6's D = 15: random search of 22 - (D + 4) = 3 evaluations
    args = _identify([str(path), "--preset", "random", "--budget", "22", "--out", str(tmp_path / "out")])
    page = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    pngs = sorted(p.name for p in (tmp_path / "out").glob("*.png"))
    assert "observed_vs_predicted.png" in pngs and "pairs.png" in pngs
    assert len(_self_contained(page)) == len(pngs) == 4          # every figure embedded
    assert "rod-length" in page and "rods measure 1.740 m" in page and "sampling" in page   # physics.checks
    assert "SHA-256" in page and str(path) in page
    assert html.escape(command_line("identify", args)) in page


def test_command_line_spells_out_every_option_the_run_used() -> None:
    args = argparse.Namespace(data=["a b.nc", "c.nc"], preset="bo", budget=10, no_progress=True, skip_checks=False,
                              journal=None, held_out=[], effects=["x", "y"], func=print, command="identify")
    assert command_line("identify", args) == ("tensegrid identify 'a b.nc' c.nc --preset bo --budget 10 "
                                              "--no-progress --effects x y")


def test_multi_line_text_keeps_its_line_breaks() -> None:
    """The model inadequacy block is one line per parameter: a paragraph, a bullet or a table cell
    shows each on its own line, escaped."""
    block = inadequacy_text(at_bounds(push_space(), np.array([1.5, 1.0])))
    lines = block.split("\n")
    assert len(lines) == 4                                       # the head, m, mu, what it means
    page = Page("t")
    page.paragraph(block, kind="warning")
    page.bullets(["a < b\nc"])
    page.table(["cell"], [["x & y\nz"]])
    out = page.render()
    assert '<p class="warning">' + "<br>\n".join(html.escape(line) for line in lines) + "</p>" in out
    assert "<li>a &lt; b<br>\nc</li>" in out and "<td>x &amp; y<br>\nz</td>" in out


def _push_belief(p: np.ndarray, verdicts: list[str], reasons: list[str], **attrs: object) -> Belief:
    dec = Identity(push_space())
    grid = Grid.for_decoder(dec, points_per_dim=11)
    return Belief.from_posterior(grid.to_dataarray(p / p.sum()), dec, grid, verdicts=verdicts, reasons=reasons,
                                 attrs=attrs)


def test_plain_words_say_how_much_of_the_prior_range_is_left_and_why() -> None:
    u = np.stack(np.meshgrid(np.linspace(0, 1, 11), np.linspace(0, 1, 11), indexing="ij"), -1).reshape(-1, 2)
    p = np.exp(-0.5 * ((u[:, 0] - 0.5) / 0.05) ** 2)            # m narrow, mu flat
    b = _push_belief(p, ["identified", "not identified"], ["narrowing: std is 9% of the prior's",
                                                          "segment consistency: t0/w0 gives [...]"])
    m = b.marginals()
    share = (float(m["upper"][0]) - float(m["lower"][0])) / (b.space.upper[0] - b.space.lower[0])
    assert plain_verdict(b, 0).startswith(f"The data pin it down: they narrow it to {share:.0%} of its prior range")
    assert "different parts of the data put its best value in different places" in plain_verdict(b, 1)
    pinned = [a.as_dict() for a in at_bounds(b.space, np.array([1.0, 1.0]))]        # mu at its upper bound
    b = _push_belief(p, ["identified", "not identified"], ["narrowing: ...", "at bound: ..."], at_bounds=pinned)
    assert plain_verdict(b, 1).startswith("The fit presses against the upper end of its prior range (1):")


def _t6_belief(p_of_u: object) -> Belief:
    """A Belief over 256 Sobol cells of the T6 box with P = p_of_u(cells in the unit box)."""
    dec = Identity(T6)
    grid = SobolCandidates.for_decoder(dec, n=256, seed=0)
    p = p_of_u(np.asarray(grid.points))                         # type: ignore[operator]
    return Belief.from_posterior(grid.to_dataarray(p / p.sum()), dec, grid)


def test_marginals_have_plain_ticks_a_y_label_and_the_legend_outside_the_panels(tmp_path) -> None:
    b = _t6_belief(lambda u: np.exp(-0.5 * ((u[:, 13] - 0.5) / 0.1) ** 2))    # narrow in motor_friction
    fig = plot_marginals(b.P, b.theta, T6, tmp_path / "m.png", marginals=b.marginals(), truth=T6.nominal)
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.axison]
    assert len(panels) == T6.dim and panels[0].get_ylabel()
    for ax in panels:
        assert ax.xaxis.get_offset_text().get_text() == "" and ax.yaxis.get_offset_text().get_text() == ""
        assert all(len(t.get_text()) <= 5 for t in ax.get_xticklabels()), [t.get_text() for t in ax.get_xticklabels()]
        assert ax.get_legend() is None
    assert fig.legends                                          # one legend, under the panels
    radius = panels[T6.index("motor_radius")]
    assert "10^{-3}" in radius.get_xlabel() and "m]" in radius.get_xlabel()


def test_pairs_show_the_most_correlated_parameters(tmp_path) -> None:
    ridge = lambda u: np.exp(-0.5 * ((u[:, 2] - u[:, 9]) / 0.08) ** 2 - 0.5 * ((u[:, 4] - u[:, 9]) / 0.2) ** 2)  # noqa: E731
    b = _t6_belief(ridge)
    rho = correlation(b.theta, b.p)
    assert set(most_correlated(rho, 3)) == {2, 4, 9} and set(most_correlated(rho, 3)[:2]) == {2, 9}
    fig = plot_pairs(b, tmp_path / "pairs.png", truth=T6.nominal)
    assert fig is not None and (tmp_path / "pairs.png").stat().st_size > 10_000
    labels = {ax.get_xlabel().split(" [")[0] for ax in fig.axes if ax.get_xlabel()}
    assert labels == {T6.names[2], T6.names[4], T6.names[9]}


def test_error_trace_has_the_unit_of_E_and_the_gauss_newton_step(push_run, tmp_path) -> None:
    result = IdentificationResult.load(f"{push_run.out}/result.nc")
    assert result.config["local_step"]
    fig = plot_error_trace(result, tmp_path / "e.png")
    ax = fig.axes[0]
    assert ax.get_ylabel() == "error E [m²]"
    assert any("Gauss-Newton step" in t.get_text() for t in ax.get_legend().get_texts())


def _walk(nan_rows: bool) -> xr.Dataset:
    """12 nodes translating along x at 1 m/s, sampled at 100 Hz; with rows 5 (all nodes) and 8 (one node) NaN."""
    t = np.arange(20) * 0.01
    base = np.random.default_rng(0).normal(size=(12, 3))
    nodes = base[None] + np.array([1.0, 0.0, 0.0])[None, None] * t[:, None, None]
    if nan_rows:
        nodes[5] = np.nan
        nodes[8, 3] = np.nan
    return xr.Dataset({"nodes": (("time", "node", "axis"), nodes)}, coords={"time": t, "axis": list("xyz")})


def test_observed_centre_of_mass_with_nan_samples_neither_jumps_nor_warns(tmp_path) -> None:
    clean, gappy = _walk(False), _walk(True)
    pred = {"model": clean["nodes"] + 0.01}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plot_observed_vs_predicted(gappy, pred, tmp_path / "ovp.png", note="a note")
        fig = observed_vs_predicted_figure(gappy, pred)
    expected = clean["nodes"].values.mean(axis=1)
    for k in range(3):
        y = np.asarray(fig.axes[k].lines[0].get_ydata(), dtype=float)
        assert np.isnan(y[[5, 8]]).all()                        # gaps where a node is missing, not jumps
        keep = np.ones(y.size, bool)
        keep[[5, 8]] = False
        np.testing.assert_allclose(y[keep], expected[keep, k], rtol=0, atol=1e-12)
    plt.close(fig)


def test_rollout_note_explains_a_best_theta_that_drifts_more_than_nominal() -> None:
    assert "restarted from each observed state" in rollout_note({"nominal": 0.1, "best": 0.3})
    assert rollout_note({"nominal": 0.3, "best": 0.1}) == ""
