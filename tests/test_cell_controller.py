"""A cell's controller, declared once (`[controller]` of a cell file): the tool and base slots its programs write and
select, and the online correction's size and rate limits, carried into `export` (KRL's `TOOL_DATA[n]`,
`BASE_DATA[n]`, the RSI context's POSCORR limits), `lab --online` and `online --serve`; a typed flag overrides the
cell; a bad value is refused naming the file and the key; the online limits do nothing to a command without an
online correction."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from test_program_structure import _export, check_rsi

from twin.cli import main
from twin.errors import DataFileError
from twin.process.cell_file import read_cell_file
from twin.robot.controller import DEFAULT_BASE_NUMBER, DEFAULT_TOOL_NUMBER

HEAD = 'format = "tx200-twin-cell/1"\nrobot = "kr210"\n'


def _cell(folder: Path, controller: str) -> Path:
    cell = folder / "cell.toml"
    cell.write_text(HEAD + "[controller]\n" + controller, encoding="utf-8")
    return cell


@pytest.fixture(scope="module")
def groove_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("groove") / "groove.csv"
    assert main(["path", "--shape", "groove", "--robot", "kr210", "--out", str(out)]) == 0
    return out


def test_the_cells_slots_are_the_programs_and_a_typed_flag_beats_them(groove_csv: Path, tmp_path: Path) -> None:
    cell = _cell(tmp_path, "tool_number = 7\nbase_number = 9\n")
    src = _export(groove_csv, "kr210", tmp_path / "cell" / "ISF.src", "--cell", str(cell))["ISF.src"]
    assert "$TOOL=TOOL_DATA[7]" in src and "$BASE=BASE_DATA[9]" in src and "TOOL_DATA[16]" not in src
    src = _export(groove_csv, "kr210", tmp_path / "typed" / "ISF.src", "--cell", str(cell),
                  "--tool-number", "5")["ISF.src"]
    assert "$TOOL=TOOL_DATA[5]" in src and "$BASE=BASE_DATA[9]" in src
    src = _export(groove_csv, "kr210", tmp_path / "none" / "ISF.src")["ISF.src"]  # no cell: the defaults, never 1
    assert f"$TOOL=TOOL_DATA[{DEFAULT_TOOL_NUMBER}]" in src and f"$BASE=BASE_DATA[{DEFAULT_BASE_NUMBER}]" in src


def test_the_cells_correction_limit_is_the_online_programs_and_the_servers(groove_csv: Path, tmp_path: Path,
                                                                          capsys: pytest.CaptureFixture[str]) -> None:
    cell = _cell(tmp_path, "max_correction_mm = 8.0\nmax_rate_mm_s = 30.0\n")
    check_rsi(_export(groove_csv, "kr210", tmp_path / "rsi" / "ISF.src", "--cell", str(cell), "--online"), limit=8.0)
    # an offline program and a lab without --online: the cell's online limits are not theirs, and not refused
    assert main(["export", str(groove_csv), "--cell", str(cell), "--out", str(tmp_path / "offline" / "ISF.src")]) == 0
    assert main(["lab", "--scenario", "nominal", "--seed", "1", "--cell", str(cell), "--commanded", str(groove_csv),
                 "--out", str(tmp_path / "run")]) == 0
    capsys.readouterr()
    # the server takes it (a session with no robot: exit 1, its summary says the limit)
    assert main(["online", "--serve", "rsi", "--port", "0", "--cell", str(cell), "--cycles", "1",
                 "--start-timeout-s", "0.1", "--json", "-"]) == 1
    said = json.loads(capsys.readouterr().out)
    assert said["limit_mm"] == 8.0 and said["rate_mm_s"] == 30.0 and said["cycles"] == 0
    assert main(["online", "--serve", "rsi", "--port", "0", "--cell", str(cell), "--cycles", "1",
                 "--start-timeout-s", "0.1", "--max-correction-mm", "3", "--json", "-"]) == 1
    assert json.loads(capsys.readouterr().out)["limit_mm"] == 3.0  # a typed flag beats the cell


@pytest.mark.parametrize(("line", "needle"), [
    ("tool_number = 0", "controller.tool_number = 0: expected a whole number 1 to 16"),
    ("tool_number = 2.5", "controller.tool_number = 2.5"),
    ("base_number = 33", "controller.base_number = 33: expected a whole number 1 to 32"),
    ("base_number = true", "controller.base_number = True"),
    ("max_correction_mm = 0", "controller.max_correction_mm = 0: expected a number above 0"),
    ("max_correction_mm = 80.0", "controller.max_correction_mm = 80.0: expected 0 to 50 mm"),
    ("max_rate_mm_s = \"fast\"", "controller.max_rate_mm_s = 'fast': expected a number"),
    ("tool = 3", "unknown key(s) ['controller.tool']"),
])
def test_a_bad_controller_value_is_refused_naming_the_file_and_key(tmp_path: Path, line: str, needle: str,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    cell = _cell(tmp_path, line + "\n")
    with pytest.raises(DataFileError, match=r"cell\.toml") as refused:
        read_cell_file(cell)
    assert needle in str(refused.value), str(refused.value)
    out = tmp_path / "ISF.src"
    assert main(["export", str(tmp_path / "missing.csv"), "--cell", str(cell), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err and not out.exists()


def test_the_cell_records_its_controller(tmp_path: Path) -> None:
    cell = read_cell_file(_cell(tmp_path, "tool_number = 3\nmax_correction_mm = 8\n"))
    assert cell.controller == {"tool_number": 3, "max_correction_mm": 8.0}
    assert cell.record()["controller"] == {"tool_number": 3, "max_correction_mm": 8.0}
    assert "controller" not in read_cell_file(_cell(tmp_path, "")).record()  # none declared: none recorded


def test_the_cells_correction_limit_is_the_online_labs(tmp_path: Path) -> None:
    """`lab --plant dynamic --online --cell`: the compensator the plant's controller runs takes the cell's limit."""
    cell = tmp_path / "cell.toml"
    cell.write_text('format = "tx200-twin-cell/1"\nrobot = "tx200"\n[controller]\nmax_correction_mm = 7.5\n')
    cone = tmp_path / "cone.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "30", "--depth-mm", "1", "--out", str(cone)]) == 0
    assert main(["lab", "--plant", "dynamic", "--scenario", "nominal", "--seed", "1", "--online", "--cell", str(cell),
                 "--commanded", str(cone), "--out", str(tmp_path / "run")]) == 0
    meta = json.loads((tmp_path / "run" / "meta.json").read_text())
    assert meta["online"]["settings"]["max_correction_mm"] == 7.5


def test_another_robot_than_the_cells_does_not_take_its_controller(tmp_path: Path) -> None:
    """`--robot` naming another robot than the cell's: the cell's controller is the cell robot's, not used."""
    import argparse

    from twin.cli._common import apply_cell

    cell = _cell(tmp_path, "tool_number = 7\nmax_correction_mm = 8\n")
    args = argparse.Namespace(cell=cell, robot="tx200", tool_number=None, max_correction_mm=None, online=True)
    apply_cell(args)
    assert args.tool_number == DEFAULT_TOOL_NUMBER and args.max_correction_mm == 5.0
    assert "controller" not in args.cell_record
    args = argparse.Namespace(cell=cell, robot=None, tool_number=None, max_correction_mm=None, online=True)
    apply_cell(args)
    assert args.tool_number == 7 and args.max_correction_mm == 8.0 and args.cell_record["controller"]["tool_number"] == 7


def test_the_cells_rate_limit_is_the_online_labs_and_the_flag_overrides_it(tmp_path: Path) -> None:
    """`lab --online`: the compensator takes the cell's `max_rate_mm_s` as the server does, `--max-rate-mm-s` over
    it; without `--online` the flag is refused (it would limit nothing)."""
    cell = tmp_path / "cell.toml"
    cell.write_text('format = "tx200-twin-cell/1"\nrobot = "tx200"\n[controller]\nmax_rate_mm_s = 35.0\n')
    cone = tmp_path / "cone.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "30", "--depth-mm", "1", "--out", str(cone)]) == 0
    lab = ["lab", "--plant", "dynamic", "--scenario", "nominal", "--seed", "1", "--commanded", str(cone)]
    assert main([*lab, "--online", "--cell", str(cell), "--out", str(tmp_path / "a")]) == 0
    assert json.loads((tmp_path / "a" / "meta.json").read_text())["online"]["settings"]["max_rate_mm_s"] == 35.0
    assert main([*lab, "--online", "--cell", str(cell), "--max-rate-mm-s", "80", "--out", str(tmp_path / "b")]) == 0
    assert json.loads((tmp_path / "b" / "meta.json").read_text())["online"]["settings"]["max_rate_mm_s"] == 80.0
    assert main([*lab, "--max-rate-mm-s", "80", "--out", str(tmp_path / "c")]) == 2
    assert main([*lab, "--online", "--max-rate-mm-s", "0", "--out", str(tmp_path / "d")]) == 2
    assert not (tmp_path / "c").exists() and not (tmp_path / "d").exists()
