"""Tests of `tx200-twin identify` (twin/cli/identify.py)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from twin.analysis.identify.cartesian import THESIS_KR1_N_PER_MM, THESIS_TABLE_4_2_LOADS_N
from twin.base.csvio import write_table
from twin.cli import COMMANDS
from twin.cli import identify as command
from twin.errors import InputError, TwinError


def run_command(argv: list[str]) -> int:
    """Parse with the command's own options and run it, mapping TwinError to exit code 2 like `main`."""
    parser = argparse.ArgumentParser(prog="tx200-twin identify")
    command.add_arguments(parser)
    args = parser.parse_args(argv)
    args.command = "identify"
    try:
        return command.run(args)
    except TwinError as exc:
        print(f"tx200-twin identify: error: {exc}")
        return 2


@pytest.fixture
def loads_csv(tmp_path: Path) -> Path:
    d_mm = np.linalg.solve(THESIS_KR1_N_PER_MM, THESIS_TABLE_4_2_LOADS_N.T).T
    values = np.column_stack([THESIS_TABLE_4_2_LOADS_N, d_mm])
    names = ("fx_n", "fy_n", "fz_n", "dx_mm", "dy_mm", "dz_mm")
    columns = {name: values[:, k] for k, name in enumerate(names)}
    return write_table(tmp_path / "loads.csv", columns, formats=dict.fromkeys(names, ".9f"))


def test_identify_is_registered() -> None:
    assert COMMANDS["identify"] == "identify"
    assert command.HELP and "\n" not in command.HELP


def test_method1_writes_json_and_prints_the_matrix(
    loads_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "kr.json"
    assert run_command(["--method", "1", "--loads", str(loads_csv), "--json", str(out)]) == 0
    payload = json.loads(out.read_text())
    np.testing.assert_allclose(payload["k_r_n_per_mm"], THESIS_KR1_N_PER_MM, rtol=1e-6)
    assert payload["method"] == 1 and payload["rank"] == 3 and payload["loads"] == str(loads_csv)
    assert len(payload["residuals_n"]) == 5 and payload["condition_number"] == pytest.approx(16.7, abs=0.1)
    printed = capsys.readouterr().out
    assert "K_R [N/mm]" in printed and "716.50" in printed and "1080.00" in printed


def test_json_to_stdout_is_pure_json(loads_csv: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert run_command(["--loads", str(loads_csv), "--json", "-"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["rank"] == 3
    assert "K_R [N/mm]" in captured.err


def test_refuses_to_overwrite_the_loads_file(loads_csv: Path) -> None:
    before = loads_csv.read_text()
    with pytest.raises(InputError, match="refusing to overwrite input file"):
        command.run(argparse.Namespace(method=1, loads=loads_csv, run_dir=None, json=str(loads_csv), write_model=None))
    assert run_command(["--loads", str(loads_csv), "--json", str(loads_csv)]) == 2
    assert loads_csv.read_text() == before


def test_method2_without_run_dir_is_an_input_error() -> None:
    with pytest.raises(InputError, match="RUN_DIR"):
        command.run(argparse.Namespace(method=2, loads=None, run_dir=None, json=None, write_model=None))


def test_method1_without_loads_is_an_input_error() -> None:
    with pytest.raises(InputError, match="--loads"):
        command.run(argparse.Namespace(method=1, loads=None, run_dir=None, json=None, write_model=None))


def test_singular_load_file_exits_with_code_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "flat.csv"
    path.write_text(
        "fx_n,fy_n,fz_n,dx_mm,dy_mm,dz_mm\n1000,0,0,1.0,0,0\n2000,0,0,2.0,0,0\n0,0,1000,0,0,1.0\n"
    )
    assert run_command(["--loads", str(path)]) == 2
    assert "rank 2" in capsys.readouterr().out
