"""The carrying of a per-axis force scale: `discrepancy` writes `force_scale` and `force_scale_in_plane` to the model
file, and the next run's gap shrinks (issue #47: everything named is carried).

This checks the mechanics on the quasi-static lab, which shares the twin: the hidden sheet is the default FE history
scaled per axis here, the form the twin carries. Finding it in a form the library does not have is
`tests/test_plant_changes.py::test_a_dry_sheet_on_the_plant_*` (the plant's own sheet, its friction raised).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from twin.cli import main
from twin.lab.virtual import run_lab
from twin.process.description import Process
from twin.process.fe.load import default_force_history
from twin.process.force.registry import in_plane_ratio
from twin.runs.write import write_run
from twin.sim.model_file import read_model_file
from twin.sim.spec import TwinSpec

#: The hidden per-axis factors (x, y, z): the in-plane force 30 % up, the axial 10 % down.
AXES = np.array([1.17, 1.0, 0.90])


def _hidden_spec() -> TwinSpec:
    history = default_force_history()
    return TwinSpec(process=Process(history=replace(history, f_sheet_n=history.f_sheet_n * AXES)))


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory, nominal_path: tuple[np.ndarray, np.ndarray]) -> dict[int, Path]:
    t_s, p_m = nominal_path
    root = tmp_path_factory.mktemp("axes")
    out = {}
    for seed in (11, 12):
        run, truth = run_lab(t_s, p_m, scenario="nominal", seed=seed, spec=_hidden_spec())
        out[seed] = write_run(root / f"run{seed}", run, truth=truth)
        (out[seed] / "truth.json").unlink()
    return out


def test_the_in_plane_ratio_reads_a_per_axis_scale() -> None:
    history = default_force_history()
    assert in_plane_ratio(replace(history, f_sheet_n=2.0 * history.f_sheet_n), history) == 1.0  # uniform: none
    r = in_plane_ratio(replace(history, f_sheet_n=history.f_sheet_n * AXES), history)
    assert r == pytest.approx(AXES[0] / AXES[2], rel=0.02)  # the groove's in-plane force is along x


def test_a_per_axis_force_scale_is_carried_and_shrinks_the_next_runs_gap(runs: dict[int, Path], tmp_path: Path,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    model, found = tmp_path / "m.json", tmp_path / "found.json"
    assert main(["discrepancy", str(runs[11]), "--model-out", str(model), "--json", str(found), "--no-learn"]) == 0
    report = json.loads(found.read_text())
    assert report["effect"] == "force_scale", report["effect"]
    effects = read_model_file(model).effects
    assert effects.force_scale == pytest.approx(AXES[2], abs=0.05)
    assert effects.get("force_scale_in_plane") == pytest.approx(AXES[0] / AXES[2], abs=0.08)
    gaps = {}
    for name, extra in (("declared", []), ("found", ["--model", str(model)])):
        out = tmp_path / f"{name}.json"
        assert main(["replay", str(runs[12]), *extra, "--json", str(out)]) == 0
        gaps[name] = json.loads(out.read_text())
    capsys.readouterr()
    for key in ("position_rms_mm", "force_rms_n"):
        assert gaps["found"][key] < 0.5 * gaps["declared"][key], (key, gaps)
