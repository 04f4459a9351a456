"""Tests of `tx200-twin compensate` (twin/cli/compensate.py) and its pipeline with `lab` and `check`.

The formula runs on the whole groove (cheap); the twin iteration runs on a short ideal path (`--ideal`, the
groove's first two passes) to keep the file fast. The whole-groove twin pipeline is in
tests/test_gain_regression.py.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from twin.base.resources import data_file
from twin.cli import COMMANDS, main
from twin.cli import compensate as command
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.runs.read import read_commanded_csv
from twin.runs.write import write_path_csv

HISTORY = data_file("fe_force_history.csv")  # the shipped half-symmetric export (fx_half_n, fz_half_n)


def run_json(argv: list[str], capsys: pytest.CaptureFixture[str], code: int = 0) -> dict[str, Any]:
    """Run `tx200-twin ARGV --json -`, check the exit code and return the JSON (stdout must be pure JSON)."""
    assert main([*argv, "--json", "-"]) == code
    payload: dict[str, Any] = json.loads(capsys.readouterr().out)
    return payload


def fails(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run `tx200-twin ARGV`, expect exit code 2 and return stderr."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"tx200-twin {argv[0]}: error: ")
    return err


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("cli_compensate")


@pytest.fixture(scope="module")
def short_ideal(work: Path) -> Path:
    """The groove's first two passes as an ideal-path CSV (282 samples)."""
    path = groove_path()
    keep = path.pass_index <= 2
    short = ToolPath(path.t_s[keep], path.p_sheet_m[keep], path.pass_index[keep], path.direction[keep])
    return write_path_csv(short, work / "ideal_short.csv")


@pytest.fixture(scope="module")
def stiffness(work: Path) -> Path:
    """Method 1 K_R from the lab's load test (seed 1), as written by `identify --json`."""
    loads, out = work / "loads.csv", work / "kr_method1.json"
    assert main(["lab", "--scenario", "loadtest", "--seed", "1", "--out", str(loads)]) == 0
    assert main(["identify", "--method", "1", "--loads", str(loads), "--json", str(out)]) == 0
    return out


def test_compensate_is_registered() -> None:
    assert COMMANDS["compensate"] == "compensate"
    assert command.HELP and "\n" not in command.HELP


def test_formula_writes_a_commanded_path_with_gain_one(
    work: Path, stiffness: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    out = work / "formula.csv"
    payload = run_json(
        ["compensate", "--method", "formula", "--stiffness", str(stiffness), "--out", str(out)], capsys
    )
    print(
        f"\nCLI formula: gain {payload['gain']:.4f}, predicted residual (twin) "
        f"{payload['predicted_residual_rms_mm']:.4f} mm rms / "
        f"{payload['predicted_residual_max_mm']:.4f} mm max"
    )
    assert payload["method"] == "formula" and payload["iterations"] == 0
    assert payload["gain"] == pytest.approx(1.0, abs=0.02)
    assert payload["history"]["symmetry"] == "half"
    # 0.360 measured (0.074 on a frictionless robot): Eq. 4.28's linear C cannot cancel the joint-friction
    # offsets that flip at every reversal; `compensate --method twin` does (test below)
    assert payload["predicted_residual_rms_mm"] < 0.5
    assert 2.0 < payload["correction_max_mm"] < 4.0  # 2.81 measured (peak deflection ~2.8 mm)
    commanded = read_commanded_csv(out)
    ideal = groove_path()
    np.testing.assert_allclose(commanded.t_s, ideal.t_s, atol=1e-6)
    correction_mm = 1e3 * np.max(np.linalg.norm(commanded.values - ideal.p_sheet_m, axis=1))
    assert correction_mm == pytest.approx(payload["correction_max_mm"], abs=1e-3)


def test_twin_then_lab_then_check_meets_the_ideal_path(
    work: Path, short_ideal: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    cmd, run_dir = work / "twin_short.csv", work / "run_compensated"
    comp = run_json(
        ["compensate", "--method", "twin", "--ideal", str(short_ideal), "--out", str(cmd)], capsys
    )
    assert 1 <= comp["iterations"] <= 12
    assert comp["converged"] and comp["predicted_residual_rms_mm"] <= 0.01  # the default tolerance, rms
    assert comp["gain"] == pytest.approx(1.0, abs=0.02)  # 1.002 measured on passes 1-2
    lab = ["lab", "--scenario", "compensated", "--commanded", str(cmd), "--seed", "2", "--out", str(run_dir)]
    assert main(lab) == 0
    capsys.readouterr()
    checked = run_json(["check", str(run_dir), "--ideal", str(short_ideal)], capsys)
    print(
        f"\nCLI twin (passes 1-2): compensate gain {comp['gain']:.4f}; lab residual "
        f"{checked['residual_rms_mm']:.4f} mm rms / {checked['residual_max_mm']:.4f} mm max, check gain "
        f"{checked['gain']:.4f}"
    )
    assert checked["residual_rms_mm"] <= 0.06
    assert checked["residual_max_mm"] <= 0.15
    assert checked["gain"] == pytest.approx(1.0, abs=0.02)
    assert sorted(checked["per_pass"]) == ["1", "2"]


def test_unchecked_half_history_declared_full_reproduces_gain_one_half(
    work: Path, stiffness: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    argv = [
        "compensate",
        "--method",
        "formula",
        "--stiffness",
        str(stiffness),
        "--out",
        str(work / "bug.csv"),
    ]
    argv += ["--history", str(HISTORY), "--symmetry", "full", "--unchecked-symmetry"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "warning:" in printed and "force scale of 0.5" in printed
    payload = run_json([*argv[:6], str(work / "bug2.csv"), *argv[7:]], capsys)
    assert payload["gain"] == pytest.approx(0.5, abs=0.05)
    assert payload["history"]["symmetry"] == "full"
    assert payload["correction_max_mm"] < 1.6  # half of the 2.8 mm


# --- bad inputs ---------------------------------------------------------------------------------------------


def test_half_history_declared_full_without_the_escape_hatch_is_refused(
    work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["compensate", "--method", "twin", "--history", str(HISTORY), "--symmetry", "full"]
    err = fails([*argv, "--out", str(work / "never.csv")], capsys)
    assert "half-symmetric" in err and "symmetry='full'" in err
    assert not (work / "never.csv").exists()


def test_formula_without_stiffness_is_a_clear_error(work: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = fails(["compensate", "--method", "formula", "--out", str(work / "never.csv")], capsys)
    assert "--method formula needs --stiffness FILE" in err


def test_history_without_symmetry_mentions_the_doubling(
    work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["compensate", "--method", "twin", "--history", str(HISTORY), "--out", str(work / "never.csv")]
    err = fails(argv, capsys)
    assert "--symmetry half|full" in err and "doubled" in err


def test_symmetry_without_history_is_an_error(work: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = fails(
        ["compensate", "--method", "twin", "--symmetry", "half", "--out", str(work / "never.csv")], capsys
    )
    assert "--symmetry is only meaningful with --history" in err


def test_stiffness_json_without_kr_names_the_file(work: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = work / "no_kr.json"
    bad.write_text(json.dumps({"k_r_n_per_m": [[1.0, 0.0], [0.0, 1.0]]}))
    err = fails(
        ["compensate", "--method", "formula", "--stiffness", str(bad), "--out", str(work / "n.csv")], capsys
    )
    assert str(bad) in err and "missing key 'k_r_n_per_mm'" in err


def test_stiffness_json_of_wrong_shape_names_the_file(work: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = work / "kr_4x1.json"
    bad.write_text(json.dumps({"k_r_n_per_mm": [1000.0, 0.0, 0.0, 1000.0]}))
    err = fails(
        ["compensate", "--method", "formula", "--stiffness", str(bad), "--out", str(work / "n.csv")], capsys
    )
    assert str(bad) in err and "expected 2x2" in err


def test_singular_stiffness_is_an_input_error(work: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = work / "kr_singular.json"
    bad.write_text(json.dumps({"k_r_n_per_mm": [[1000.0, 1000.0], [1000.0, 1000.0]]}))
    err = fails(
        ["compensate", "--method", "formula", "--stiffness", str(bad), "--out", str(work / "n.csv")], capsys
    )
    assert "singular" in err


def test_refuses_to_write_out_over_its_stiffness_input(
    stiffness: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    before = stiffness.read_text()
    err = fails(
        ["compensate", "--method", "formula", "--stiffness", str(stiffness), "--out", str(stiffness)], capsys
    )
    assert "is the input --stiffness" in err and "an output never replaces an input" in err
    assert stiffness.read_text() == before
