"""DIR/report.html of ``tensegrid diagnose`` (criticism.html_report): self-contained, with the command, the
settings, the data files and their checks, each pass (ranking, held-out error, re-identified effect) and
the first identification's parameters with their verdicts."""
from __future__ import annotations

import argparse
import base64
import html
import re
from dataclasses import replace
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from belief import Belief, SobolCandidates, at_bounds  # noqa: E402
from belief.html_report import command_line  # noqa: E402
from criticism import Candidate, Criticism, Diagnosis, Pass  # noqa: E402
from criticism.html_report import write_diagnose_report  # noqa: E402
from criticism.report import write_report  # noqa: E402
from criticism.revisit import Revisit  # noqa: E402
from embeddings import Identity  # noqa: E402
from physics import FlopController, ParameterSpace, load_trajectory, save_trajectory, simulate  # noqa: E402
from physics.cli import main  # noqa: E402
from physics.effects import TensionLimitedActuation  # noqa: E402

T6 = ParameterSpace.t6()


@pytest.fixture(scope="module")
def two_files(tmp_path_factory) -> list[str]:
    """Two short SUPERball trajectories (nominal θ, flops toward +x and +y), saved as netCDF."""
    folder = tmp_path_factory.mktemp("data")
    flops = [simulate(T6.nominal, controller=FlopController(heading=h), duration=0.4) for h in (0.0, 1.5708)]
    return [str(save_trajectory(ds, folder / f"{k}.nc")) for k, ds in enumerate(flops)]


def _self_contained(page: str) -> list[str]:
    assert 'src="http' not in page and "href=\"http" not in page and "<link" not in page and "<script" not in page
    sources = re.findall(r'<img[^>]*\ssrc="([^"]+)"', page)
    for src in sources:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1])[:4] == b"\x89PNG"
    return sources


def _diagnosis() -> Diagnosis:
    """One pass that found and added an actuator delay, over a flat Belief of the T6 box."""
    dec = Identity(T6)
    grid = SobolCandidates.for_decoder(dec, n=64, seed=0)
    belief = Belief.from_posterior(grid.to_dataarray(np.full(grid.size, 1.0 / grid.size)), dec, grid)
    theta = T6.nominal.copy()
    delay = Candidate("actuator_delay", "effect", {"actuator_delay": 0.08}, 1.0, 0.4, 0.8, 55.0)
    floor = Candidate("re-tuned model", "floor", {"damping": 190.0}, 1.0, 2.0, 0.1, 3.0)
    crit = Criticism(theta, 1.0, 2.0, 10.0, 10.0, [delay], floor, "found", delay)
    step = Pass((), T6.names, theta, crit, {"t1": 2.0}, added="actuator_delay",
                names_after=(*T6.names, "actuator_delay"), theta_after=np.append(theta, 0.08), held_after={"t1": 0.5},
                at_bounds=at_bounds(T6, T6.upper, source="re-tuning")[:1])
    return Diagnosis([step], ("actuator_delay",), [1], belief, {"horizon": 25, "bound_tolerance": 0.01})


def test_diagnose_report_holds_the_run_the_passes_and_the_parameters(tmp_path, two_files) -> None:
    args = argparse.Namespace(data=two_files, out=str(tmp_path), held_out=None, effects=["actuator_delay"],
                              budget=40, passes=1, horizon=25, candidates=2048, seed=0, no_progress=True,
                              skip_checks=False)
    fig, ax = plt.subplots()
    ax.plot([0, 1])
    fig.savefig(tmp_path / "ranking.png")
    plt.close(fig)
    d = _diagnosis()
    path = write_diagnose_report(tmp_path, d, [load_trajectory(f) for f in two_files], args)
    page = path.read_text(encoding="utf-8")
    assert len(_self_contained(page)) == 1                      # the one figure present, embedded
    assert html.escape(command_line("diagnose", args)) in page and "tensegrid diagnose" in page
    assert "Data and checks" in page and "rods measure 1.740 m" in page and two_files[1] in page
    assert "Effects found and added: actuator_delay" in page and "actuator_delay=0.08" in page
    assert "E before [m²]" in page and "-75.0%" in page          # held-out error 2.0 -> 0.5
    assert "Model inadequacy" in page                           # the parameter the re-tuning pinned
    for name, (verdict, _) in d.belief.verdicts.items():
        assert re.search(rf"<td>{name}</td>.*?<td>{verdict}</td>", page), name
    assert "of its prior range" in page and "How to reproduce" in page


def test_a_pass_found_on_the_second_look_is_marked_and_explained(tmp_path, two_files) -> None:
    """An effect criticism ranked first without finding it, found on the second look at the stage
    (criticism.revisit) with a component: the ranking marks it, the page prints the second look,
    and a placed effect shows where it sits."""
    d = _diagnosis()
    step = d.passes[0]
    ranked = replace(step.criticism.ranking[0], explained=0.15)
    mass = Candidate("point_mass", "effect", {"point_mass": 0.5}, 1.0, 1.9, 0.05, -2.0,
                     config={"effect": "point_mass", "rod": 3, "position": -0.6}, placements=12)
    step.criticism = replace(step.criticism, ranking=[ranked, mass], verdict="unexplained", found=None)
    row = replace(ranked, explained=0.41, evidence=20.6)
    step.looks = (Revisit("actuator_delay", ("tension_limited_actuator",),
                           SimpleNamespace(effects=(TensionLimitedActuation(),)), row, True),)
    args = argparse.Namespace(data=two_files, out=str(tmp_path), held_out=None, effects=None, budget=40, passes=1,
                              horizon=25, candidates=2048, seed=0, no_progress=True, skip_checks=False)
    page = write_diagnose_report(tmp_path, d, [load_trajectory(f) for f in two_files], args).read_text()
    assert "1. actuator_delay (found)" in page
    assert "Second look at the stage with actuator_delay: tried tension_limited_actuator; kept " \
           "tension_limited_actuator" in page and "-&gt; found" in page
    assert "rod=3, position=-0.6; best of 12 places" in page


@pytest.mark.slow
def test_the_diagnose_command_writes_the_report(tmp_path, two_files, capsys) -> None:
    out = tmp_path / "out"
    assert main(["diagnose", *two_files, "--effects", "actuator_delay", "--budget", "17", "--passes", "1",
                 "--candidates", "64", "--horizon", "10", "--no-mismatch", "--out", str(out), "--no-progress"]) == 0
    assert f"wrote {out / 'report.html'}" in capsys.readouterr().out
    page = (out / "report.html").read_text(encoding="utf-8")
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert len(_self_contained(page)) == len(pngs) >= 3
    assert "tensegrid diagnose" in page and "Pass 1: model T6" in page and "actuator_delay" in page


def test_the_signature_figure_shows_an_effect_found_on_the_second_look(tmp_path, two_files) -> None:
    """criticism.report draws signature.png for an effect the second look found (with the component
    it let in), as for one criticism found itself; the page embeds it."""
    d = _diagnosis()
    d.settings["windows"] = 3
    step = d.passes[0]
    ranked = replace(step.criticism.ranking[0], theta=tuple(np.append(T6.nominal, 0.08)),
                     config={"effect": "actuator_delay"})
    step.criticism = replace(step.criticism, ranking=[ranked], verdict="unexplained", found=None)
    step.looks = (Revisit("actuator_delay", ("tension_limited_actuator",),
                           SimpleNamespace(effects=(TensionLimitedActuation(),)), replace(ranked, evidence=20.6),
                           True),)
    trajectories = [load_trajectory(f) for f in two_files]
    paths = write_report(d, trajectories, tmp_path)
    assert tmp_path / "signature.png" in paths
    args = argparse.Namespace(data=two_files, out=str(tmp_path), held_out=None, effects=None, budget=40, passes=1,
                              horizon=25, candidates=2048, seed=0, no_progress=True, skip_checks=False)
    page = write_diagnose_report(tmp_path, d, trajectories, args).read_text()
    assert len(_self_contained(page)) == 4                      # residual_time, residual_nodes, ranking, signature
