"""A cone through the command line, as a new user would run it (issue 16): path -> compensate -> lab -> check.

`--force-model auto` takes the height-map ISF model for a path that is not the FE history's groove, so the
table field's "pass_index = 11" error no longer stops `compensate --ideal cone.csv`. Measured (5 mm deep 45° cone,
40 mm across, seed 1): compensated lab run 0.035 mm rms / 0.084 mm max against the ideal path, the nominal run
1.12 mm rms.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from twin.cli import main


@pytest.fixture(scope="module")
def cone_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("cone")
    cone, cmd = base / "cone.csv", base / "cone_cmd.csv"
    assert main(["path", "--shape", "cone", "--depth-mm", "5", "--top-width-mm", "40", "--out", str(cone)]) == 0
    assert main(["compensate", "--method", "twin", "--ideal", str(cone), "--tol-mm", "0.01", "--out", str(cmd),
                 "--json", str(base / "compensate.json")]) == 0
    for name, commanded, scenario in (("nominal", cone, "nominal"), ("compensated", cmd, "compensated")):
        assert main(["lab", "--scenario", scenario, "--commanded", str(commanded), "--seed", "1",
                     "--out", str(base / name)]) == 0
    return {"cone": cone, "nominal": base / "nominal", "compensated": base / "compensated", "base": base}


def check(run: Path, ideal: Path, capsys: pytest.CaptureFixture[str]) -> dict[str, float]:
    capsys.readouterr()
    main(["check", str(run), "--ideal", str(ideal), "--json", "-"])
    payload: dict[str, float] = json.loads(capsys.readouterr().out)
    return payload


def test_a_cone_is_compensated_onto_its_path_through_the_cli(
    cone_runs: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    compensate = json.loads((cone_runs["base"] / "compensate.json").read_text())
    assert compensate["force_model"] == "isf"
    truth = json.loads((cone_runs["compensated"] / "truth.json").read_text())
    assert truth["force_model"] == "isf"
    right = check(cone_runs["compensated"], cone_runs["cone"], capsys)
    nominal = check(cone_runs["nominal"], cone_runs["cone"], capsys)
    print(f"\ncone: compensated {right['residual_rms_mm']:.3f} mm rms, nominal {nominal['residual_rms_mm']:.3f} mm")
    assert right["residual_rms_mm"] < 0.1
    assert nominal["residual_rms_mm"] > 10.0 * right["residual_rms_mm"]
    assert right["gain"] == pytest.approx(1.0, abs=0.05)


def test_the_groove_keeps_the_table_field(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compensate", "--method", "formula", "--stiffness", str(write_stiffness(tmp_path)),
                 "--out", str(tmp_path / "g.csv"), "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["force_model"] == "table"


def write_stiffness(folder: Path) -> Path:
    path = folder / "k.json"
    path.write_text(json.dumps({"k_r_n_per_mm": [[700.0, 0.0, -300.0], [0.0, 800.0, 0.0], [-300.0, 0.0, 1100.0]]}))
    return path
