"""Tests of `tx200-twin discrepancy`: JSON document, model file accepted by replay, report, no truth read."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from twin.base.resources import data_file
from twin.cli import main
from twin.lab.virtual import LabSettings, run_lab
from twin.runs.write import write_run
from twin.sim.effects import Effects
from twin.sim.model_file import read_model_file
from twin.sim.spec import TwinSpec

HIDDEN = {"tool_length_offset": 0.2}  # shows in position, force and profile
SEED = 401
NOISE_NORM_MM = math.sqrt(3.0) * 1e3 * LabSettings().tracker_noise_m
JSON_KEYS = {"effect", "effects", "parameters", "confidence", "gap_before", "gap_after", "noise", "candidates",
             "families", "explained_fraction", "remainder", "model_complete"}


@pytest.fixture(scope="module")
def hidden_run_dir(tmp_path_factory: pytest.TempPathFactory, nominal_path: tuple[np.ndarray, np.ndarray]) -> Path:
    """A lab run with a hidden tool_length_offset, written to disk, its truth.json deleted."""
    t_s, p_m = nominal_path
    run, truth = run_lab(t_s, p_m, scenario="nominal", seed=SEED, spec=TwinSpec(effects=Effects(HIDDEN)))
    directory = write_run(tmp_path_factory.mktemp("cli_discrepancy") / "run", run, truth=truth)
    (directory / "truth.json").unlink()
    return directory


@pytest.fixture(scope="module")
def workflow(hidden_run_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """One `discrepancy` call with --json FILE, --model-out and --report; returns the paths it wrote."""
    out = tmp_path_factory.mktemp("cli_discrepancy_out")
    paths = {"json": out / "found.json", "model": out / "model.json", "report": out / "report"}
    code = main([
        "discrepancy", str(hidden_run_dir), "--json", str(paths["json"]),
        "--model-out", str(paths["model"]), "--report", str(paths["report"]),
    ])
    assert code == 0
    return paths


def test_json_names_the_hidden_effect_with_every_documented_key(workflow: dict[str, Path],
                                                                hidden_run_dir: Path) -> None:
    assert not (hidden_run_dir / "truth.json").exists()
    doc = json.loads(workflow["json"].read_text())
    assert set(doc) >= JSON_KEYS
    assert doc["effect"] == "tool_length_offset"
    assert doc["effects"] == ["tool_length_offset"]
    assert doc["parameters"]["tool_length_offset"]["tool_length_offset_mm"] == pytest.approx(0.2, rel=0.15)
    # the family behind the effect's name, with its parameter, standard error and explained share
    family = doc["families"][0]
    assert family["name"] == "tool_length_offset" and family["effect_name"] == "tool_length_offset"
    assert family["parameters"]["length_mm"] == pytest.approx(0.2, abs=3.0 * family["uncertainty"]["length_mm"] + 0.02)
    assert 0.0 < family["uncertainty"]["length_mm"] < 0.02
    assert family["explained_fraction"] >= 0.9 and doc["explained_fraction"] >= 0.9
    assert doc["model_complete"] is True
    assert doc["remainder"]["words"] == "nothing left above the noise"
    assert 0.0 < doc["confidence"] <= 1.0
    for key in ("gap_before", "gap_after"):
        assert {"position_rms_mm", "force_rms_n"} <= set(doc[key])
    assert doc["gap_after"]["position_rms_mm"] <= 0.3 * doc["gap_before"]["position_rms_mm"]
    assert doc["gap_after"]["position_rms_mm"] <= 2.0 * NOISE_NORM_MM
    assert {"position_mm", "force_n"} <= set(doc["noise"])
    assert doc["noise"]["position_mm"] == pytest.approx(1e3 * LabSettings().tracker_noise_m, rel=0.15)
    assert doc["candidates"], "the candidates of the first round are listed"
    for candidate in doc["candidates"]:
        assert {"name", "score", "parameters"} <= set(candidate)
    assert doc["candidates"][0]["name"] == "tool_length_offset"


def test_model_out_is_accepted_by_replay_and_shrinks_the_gap(workflow: dict[str, Path], hidden_run_dir: Path,
                                                             tmp_path: Path) -> None:
    spec = read_model_file(workflow["model"])
    assert set(spec.effects.values) == {"tool_length_offset"}
    assert spec.joint_stiffness is None
    plain, fixed = tmp_path / "plain.json", tmp_path / "fixed.json"
    assert main(["replay", str(hidden_run_dir), "--json", str(plain)]) == 0
    assert main(["replay", str(hidden_run_dir), "--model", str(workflow["model"]), "--json", str(fixed)]) == 0
    before = json.loads(plain.read_text())["position_rms_mm"]
    after = json.loads(fixed.read_text())["position_rms_mm"]
    doc = json.loads(workflow["json"].read_text())
    assert before == pytest.approx(doc["gap_before"]["position_rms_mm"], rel=1e-6)
    assert after == pytest.approx(doc["gap_after"]["position_rms_mm"], rel=1e-6)
    assert after <= 0.3 * before


def test_report_writes_the_residual_png(workflow: dict[str, Path]) -> None:
    figure = workflow["report"] / "residual_before_after.png"
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert figure.stat().st_size > 10_000


def test_json_to_stdout_is_pure_json(hidden_run_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["discrepancy", str(hidden_run_dir), "--json", "-"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    assert doc["effect"] == "tool_length_offset"
    assert "discrepancy" in captured.err and "tool_length_offset" in captured.err


def test_missing_run_directory_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "no_such_run"
    assert main(["discrepancy", str(missing), "--json", str(tmp_path / "out.json")]) == 2
    assert str(missing.name) in capsys.readouterr().err
    assert not (tmp_path / "out.json").exists()


def test_history_without_symmetry_exits_2(hidden_run_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["discrepancy", str(hidden_run_dir), "--history", str(data_file("fe_force_history.csv"))])
    assert code == 2
    assert "--symmetry" in capsys.readouterr().err


def test_starting_from_the_model_out_finds_nothing_more(workflow: dict[str, Path], hidden_run_dir: Path,
                                                        tmp_path: Path) -> None:
    again = tmp_path / "again.json"
    code = main(["discrepancy", str(hidden_run_dir), "--model", str(workflow["model"]), "--json", str(again)])
    assert code == 0
    doc = json.loads(again.read_text())
    first = json.loads(workflow["json"].read_text())
    assert doc["effect"] == "none"
    assert doc["parameters"] == first["parameters"]
    assert doc["gap_before"]["position_rms_mm"] == pytest.approx(first["gap_after"]["position_rms_mm"], rel=1e-9)


def test_discrepancy_refuses_to_write_the_model_into_the_run(tmp_path: Path) -> None:
    from twin.errors import InputError
    from twin.sim.model_file import write_model_file

    run_dir = tmp_path / "run"
    run_dir.mkdir()
    with pytest.raises(InputError, match="refusing"):
        write_model_file(run_dir / "model.json", TwinSpec(), protect=[run_dir])
