"""`learn` from runs of different parts, each declaring its own sheet: the lab's groove (its FE history, a table of
10 passes) and a small cone (the published formula). Before, every run was replayed on the first run's sheet, so
the cone's passes past the groove's tenth failed with "pass_index = 11: the history has passes 1..10", and a
shorter cone was judged against a groove's FE forces."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from twin.analysis.learn.cell import declared_process
from twin.cli import main
from twin.runs.read import read_run
from twin.sim.model_file import write_model_file
from twin.sim.spec import TwinSpec


def test_learn_from_a_groove_and_a_cone_that_declare_different_sheets(
        clean_run_dir: Path, lab_cone_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """conftest's lab cone has 11 passes, past the groove history's 10."""
    cone_run = lab_cone_run
    groove, cone = read_run(clean_run_dir), read_run(cone_run)
    assert (declared_process(groove).force_model, declared_process(cone).force_model) == ("table", "isf")
    capsys.readouterr()
    assert main(["learn", str(clean_run_dir), str(cone_run), "--json", str(tmp_path / "learn.json")]) == 0
    words = capsys.readouterr().out
    assert "the runs declare several sheets (table, isf): the learned one, which covers them all, is taken" in words
    report = json.loads((tmp_path / "learn.json").read_text())
    assert report["sheet"]["declared_sheets"] == ["table", "isf"] and not report["sheet"]["declared_kept"]
    # each run replayed on the sheet it declares (the lab's own: its gap is the noise's), not on the groove's
    assert all(gap["position_rms_mm"] < 0.1 for gap in report["before"]), report["before"]
    robot = report["robot"]
    assert robot["observable"][:3] == [True, True, True]
    # the lab's robot is the declared twin's: each observed joint lands within 3 spreads of the prior
    for k, s, k0, seen in zip(robot["k_q_nm_per_rad"], robot["k_q_std_nm_per_rad"], robot["prior_k_q_nm_per_rad"],
                              robot["observable"], strict=True):
        assert not seen or abs(k - k0) < 3.0 * s, (k, s, k0)
    assert len(report["held_out_predicted"]) == 2
    # a declared twin whose sheet is the groove's FE history cannot be driven along the cone: named, exit 2
    model = write_model_file(tmp_path / "groove.json", TwinSpec(process=declared_process(groove)))
    assert main(["learn", str(clean_run_dir), str(cone_run), "--model", str(model)]) == 2
    err = capsys.readouterr().err
    assert f"run {cone_run}: the declared sheet (table) cannot be driven along it" in err
    assert "Traceback" not in err
