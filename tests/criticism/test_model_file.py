"""The model a diagnosis ends with, handed to identification: diagnose writes DIR/model.json
(physics.model_file), ``tensegrid identify --model`` and ``--effects`` identify with it; the
reports of a diagnosis with the mismatch stage (report figures of the augmented model, the stage
in report.html); effects measured at rest join the model before the search."""
from __future__ import annotations

import argparse
import json

import pytest
import xarray as xr

from belief.least_squares import LeastSquaresConfig
from criticism.diagnose import DiagnoseConfig, diagnose, shown_at_rest
from criticism.search import CriticismConfig
from criticism.html_report import write_diagnose_report
from criticism.mismatch import MismatchConfig
from criticism.report import diagnosis_record, diagnosis_text, write_report
from physics import FlopController, save_trajectory, simulate
from physics.cli import main
from physics.effects import ActuatorDelay, CableAnchors, GroundSlope, TensionLimitedActuation, model_space
from physics.errors import ParameterError
from physics.model_file import effects_by_name, read_model_file, write_model_file

#: Screening alone, on a short re-tuning: these tests are about the model file, not the fits.
SCREEN_ONLY = CriticismConfig(grid=3, refine=3, joint=0, local=LeastSquaresConfig(evaluations=3))


def test_a_model_file_reads_back_its_effects_in_order(tmp_path) -> None:
    effects = (TensionLimitedActuation(), CableAnchors())
    write_model_file(tmp_path / "model.json", effects, {"anchor_offset": 0.06})
    assert [e.name for e in read_model_file(tmp_path / "model.json")] == ["tension_limited_actuator", "cable_anchors"]
    assert [e.name for e in effects_by_name(["actuator_delay", "cable_anchors"])] == ["actuator_delay", "cable_anchors"]


@pytest.mark.parametrize("text, says", [("{", "is not JSON"), ('{"theta": {}}', "needs a list 'effects'"),
                                        ('{"effects": [{"effect": "magic"}]}', "unknown effect 'magic'"),
                                        ('{"effects": [{"effect": "cable_anchors"}, {"effect": "cable_anchors"}]}',
                                         "listed twice")])
def test_a_bad_model_file_is_refused_with_what_is_wrong(tmp_path, text: str, says: str) -> None:
    (tmp_path / "model.json").write_text(text)
    with pytest.raises(ParameterError, match=says):
        read_model_file(tmp_path / "model.json")
    with pytest.raises(ParameterError, match="cannot read the model file"):
        read_model_file(tmp_path / "missing.json")
    with pytest.raises(ParameterError, match=r"unknown effect\(s\) \['magic'\]; known effects are"):
        effects_by_name(["cable_anchors", "magic"])
    with pytest.raises(ParameterError, match="no effect named"):
        effects_by_name([])


@pytest.fixture(scope="module")
def anchored(tmp_path_factory) -> list[xr.Dataset]:
    """Two 0.6 s flops of the T6 whose cables sit 6 cm off the rod axis (CableAnchors)."""
    space = model_space([CableAnchors()])
    theta = space.as_array({**space.as_dict(None), "anchor_offset": 0.06})
    return [simulate(theta, controller=FlopController(h), duration=0.6, effects=[CableAnchors()], noise=2e-4, seed=k)
            for k, h in enumerate((0.0, 2.1))]


@pytest.mark.slow
def test_diagnose_writes_the_model_with_the_stage_s_components_and_identify_uses_it(tmp_path, anchored,
                                                                                      capsys) -> None:
    stage = MismatchConfig(components=(CableAnchors(),), rounds=1, local=LeastSquaresConfig(evaluations=3))
    config = DiagnoseConfig(budget=6, candidates=64, passes=1, horizon=10, mismatch=stage, criticism=SCREEN_ONLY)
    d = diagnose(anchored, held_out=[1], effects=[ActuatorDelay()], config=config, n_workers=0, progress=False)
    assert d.mismatch is not None and [e.name for e in d.mismatch.effects] == ["cable_anchors"]
    files = [str(save_trajectory(ds, tmp_path / f"{k}.nc")) for k, ds in enumerate(anchored)]
    write_report(d, anchored, tmp_path / "diag")
    record = json.loads((tmp_path / "diag" / "model.json").read_text())
    assert record["effects"][0] == {"effect": "cable_anchors"} and "anchor_offset" in record["theta"]
    args = argparse.Namespace(data=files, out=str(tmp_path / "diag"), budget=6, no_progress=True, skip_checks=False)
    page = write_diagnose_report(tmp_path / "diag", d, anchored, args).read_text(encoding="utf-8")
    assert "Engine mismatch" in page and "The mismatch stage added cable_anchors to the T6" in page
    out = tmp_path / "ident"            # BO's 8 evaluations; the T6 with cable_anchors (D = 16) keeps D + 4 = 20
    assert main(["identify", files[0], "--model", str(tmp_path / "diag" / "model.json"), "--preset", "bo",
                 "--budget", "28", "--candidates", "64", "--out", str(out), "--no-progress", "--no-next"]) == 0
    result = xr.open_dataset(out / "result.nc")
    assert "anchor_offset" in [str(p) for p in result["parameter"].values]
    assert json.loads(result.attrs["config"])["effects"] == [{"effect": "cable_anchors"}]
    box = json.loads((out / "prior_box.json").read_text())
    assert box["anchor_offset"]["upper"] == pytest.approx(0.1)
    with pytest.raises(SystemExit):         # one source of the model, not two
        main(["identify", files[0], "--effects", "cable_anchors", "--model", "x.json", "--out", str(out)])
    assert main(["identify", "--effects", "cable_anchors", files[0], "--out", str(tmp_path / "x")]) == 2
    assert "put it after the data files" in capsys.readouterr().err
    assert main(["identify", "--toy", "push", "--effects", "cable_anchors", "--out", str(tmp_path / "toy")]) == 2
    assert "the push toy has none" in capsys.readouterr().err
    assert not (tmp_path / "toy").exists()


@pytest.mark.slow
def test_a_floor_the_resting_robot_shows_tilted_joins_the_model_before_the_search(tmp_path) -> None:
    """Flops on a 2.9° floor: the slope is measured at rest and added before identifying (not ranked
    by the search), reported, and written to model.json with its measured box; level flops add nothing."""
    effects = [GroundSlope()]
    theta = model_space(effects).as_array({**model_space(effects).as_dict(None), "slope_x": 0.05})
    data = [simulate(theta, controller=FlopController(h), duration=0.6, effects=effects, noise=2e-4, seed=k)
            for k, h in enumerate((0.0, 2.1))]
    config = DiagnoseConfig(budget=6, candidates=64, passes=1, horizon=10, mismatch=None, criticism=SCREEN_ONLY)
    d = diagnose(data, held_out=[1], effects=[GroundSlope(), ActuatorDelay()], config=config, n_workers=0,
                 progress=False)
    assert [e.name for e in d.measured] == ["ground_slope"] and d.found[0] == "ground_slope"
    assert d.passes[0].effects == ("ground_slope",)
    assert [c.name for c in d.passes[0].criticism.ranking] == ["actuator_delay"]
    (slope_x, _slope_y) = d.measured[0].parameters()
    assert slope_x.lower < 0.05 < slope_x.upper
    assert "measured at rest: ground_slope (slope_x=" in diagnosis_text(d)
    assert diagnosis_record(d)["measured"][0]["effect"] == "ground_slope"
    write_report(d, data, tmp_path / "diag")
    record = json.loads((tmp_path / "diag" / "model.json").read_text())
    assert record["effects"][0]["effect"] == "ground_slope" and "measured" in record["effects"][0]
    level = [simulate(None, controller=FlopController(0.0), duration=0.6, noise=2e-4, seed=0)]
    assert shown_at_rest(level, [GroundSlope(), ActuatorDelay()]) == ()
