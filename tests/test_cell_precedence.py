"""One precedence for the sheet placement and the tool (`twin.analysis.tool_choice.PRECEDENCE`, issue #46): an
explicit flag > the run's record > the cell file > the robot's defaults; each program states on its first comment
lines the sheet frame and tool it was written with and where they came from."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from test_import_mapping import cell as raw_cell  # noqa: F401  (the synthetic cell's raw exports and mapping)

from twin.cli import main

CELL = """format = "tx200-twin-cell/1"
name = "abb-cell"
robot = "irb6640"
[tool]
length_mm = 300.0
mass_kg = 8.0
[sheet]
origin_mm = [1600.0, 0.0, 500.0]
yaw_deg = 30.0
"""


def _wobj(mod: Path, quaternion: bool = False) -> list[float]:
    """The work object's user frame of a RAPID module (wSheet's `[[x,y,z],[q1,q2,q3,q4]]`): its origin [mm], or
    its quaternion."""
    line = next(line for line in mod.read_text().splitlines() if "wobjdata wSheet" in line)
    numbers = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", line.split("[[", 1)[1])]
    return numbers[3:7] if quaternion else numbers[:3]


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A short cone path and a quasi-static lab run of the IRB 6640 with its sheet at (1600, 0, 500) mm."""
    tmp = tmp_path_factory.mktemp("precedence")
    path, run = tmp / "cone.csv", tmp / "n1"
    assert main(["path", "--shape", "cone", "--top-width-mm", "40", "--depth-mm", "2", "--robot", "irb6640",
                 "--origin-mm", "1600", "0", "500", "--out", str(path)]) == 0
    assert main(["lab", "--scenario", "nominal", "--seed", "1", "--commanded", str(path), "--robot", "irb6640",
                 "--origin-mm", "1600", "0", "500", "--out", str(run)]) == 0
    return path, run


def test_export_of_a_run_uses_its_placement_and_a_flag_beats_it(made: tuple[Path, Path], tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    path, run = made
    out = tmp_path / "ISF.mod"
    assert main(["export", str(path), "--run", str(run), "--out", str(out)]) == 0
    assert _wobj(out) == pytest.approx([1600.0, 0.0, 500.0])  # was the robot's default (1700, 0, 500)
    head = out.read_text().splitlines()[:6]
    assert any("origin (1600, 0, 500) mm (from the run" in line and line.lstrip().startswith("!") for line in head)
    assert any("tool:" in line and "from the run" in line for line in head)
    assert main(["export", str(path), "--run", str(run), "--origin-mm", "1650", "0", "500",
                 "--out", str(tmp_path / "B.mod")]) == 0
    assert _wobj(tmp_path / "B.mod") == pytest.approx([1650.0, 0.0, 500.0])
    assert "(from --origin-mm)" in (tmp_path / "B.mod").read_text()


def test_an_explicit_flag_beats_the_cell_and_the_cell_beats_the_robot(made: tuple[Path, Path], tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    path, _ = made
    cell = tmp_path / "cell.toml"
    cell.write_text(CELL.replace("yaw_deg = 30.0", "yaw_deg = 0.0"))
    assert main(["export", str(path), "--cell", str(cell), "--out", str(tmp_path / "A.mod"), "--json", "-"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["sheet_origin_in_base_mm"] == pytest.approx([1600.0, 0.0, 500.0])
    assert (record["tool_length_mm"], record["tool_mass_kg"]) == (300.0, 8.0)
    text = (tmp_path / "A.mod").read_text()
    assert "300 mm flange to tip (from the cell abb-cell" in text and "8 kg (from the cell abb-cell" in text
    cell.write_text(CELL)  # yaw 30 in the cell; an explicit --yaw-deg 0 wins
    assert main(["export", str(path), "--cell", str(cell), "--out", str(tmp_path / "T.mod")]) == 0
    assert _wobj(tmp_path / "T.mod", quaternion=True) == pytest.approx([0.965926, 0.0, 0.0, 0.258819], abs=1e-5)
    capsys.readouterr()
    assert main(["export", str(path), "--cell", str(cell), "--yaw-deg", "0", "--tool-length-mm", "280",
                 "--out", str(tmp_path / "Y.mod"), "--json", "-"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["tool_length_mm"] == 280.0
    text = (tmp_path / "Y.mod").read_text()
    assert "yaw 0 deg (from --yaw-deg)" in text and "280 mm flange to tip (from --tool-length-mm)" in text
    assert _wobj(tmp_path / "Y.mod", quaternion=True) == pytest.approx([1.0, 0.0, 0.0, 0.0])


def test_the_run_beats_the_cell_and_another_robot_is_refused(made: tuple[Path, Path], tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    path, run = made
    cell = tmp_path / "cell.toml"
    cell.write_text(CELL.replace("[1600.0, 0.0, 500.0]", "[1500.0, 0.0, 500.0]").replace("yaw_deg = 30.0", ""))
    assert main(["export", str(path), "--run", str(run), "--cell", str(cell), "--out", str(tmp_path / "R.mod")]) == 0
    assert _wobj(tmp_path / "R.mod") == pytest.approx([1600.0, 0.0, 500.0])
    kr = tmp_path / "kr.toml"
    kr.write_text(CELL.replace('"irb6640"', '"kr210"'))
    capsys.readouterr()
    assert main(["export", str(path), "--run", str(run), "--cell", str(kr), "--out", str(tmp_path / "K.mod")]) == 2
    err = capsys.readouterr().err
    assert "'kr210'" in err and "'irb6640'" in err and "Traceback" not in err


def test_a_robot_flag_other_than_the_cells_drops_the_cells_sheet(made: tuple[Path, Path], tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    path, _ = made
    kr = tmp_path / "kr.toml"
    kr.write_text(CELL.replace('"irb6640"', '"kr210"'))
    assert main(["export", str(path), "--cell", str(kr), "--robot", "irb6640", "--out", str(tmp_path / "I.mod"),
                 "--json", "-"]) == 0
    captured = capsys.readouterr()
    assert "not the cell's robot kr210" in captured.err
    record = json.loads(captured.out)
    assert "default sheet origin" in record["tool_and_base_from"] and record["tool_length_mm"] != 300.0


def test_info_prints_the_cells_sheet_origin(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cell = tmp_path / "cell.toml"
    cell.write_text(CELL)
    assert main(["info", "--cell", str(cell), "--json", "-"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["robot"] == "irb6640" and payload["sheet_origin_m"] == pytest.approx([1.6, 0.0, 0.5])
    assert payload["sheet_yaw_deg"] == pytest.approx(30.0) and "abb-cell" in payload["sheet_from"]["origin"]
    assert main(["info", "--cell", str(cell)]) == 0
    assert "sheet origin [m] [1.6 0.  0.5] (from the cell abb-cell" in capsys.readouterr().out


def _mapping(raw_cell: Path, tmp_path: Path, run_table: str) -> Path:  # noqa: F811
    for name in ("cmd.csv", "tracker.csv", "forces.csv"):
        (tmp_path / name).write_bytes((raw_cell.parent / name).read_bytes())
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(raw_cell.read_text().replace('[run]\nscenario = "synthetic"\n', run_table, 1))
    return mapping


def test_import_records_the_robot_and_placement_and_export_follows(
        raw_cell: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: F811
    mapping = _mapping(raw_cell, tmp_path, '[run]\nrobot = "irb6640"\norigin_mm = [1600.0, 0.0, 500.0]\n')
    assert main(["import", "--mapping", str(mapping), "--out", str(tmp_path / "imp1")]) == 0
    assert "robot irb6640, sheet origin (1600, 0, 500) mm" in capsys.readouterr().out
    meta = json.loads((tmp_path / "imp1" / "meta.json").read_text())
    assert meta["robot"] == "irb6640" and meta["placement"]["origin_base_mm"] == [1600.0, 0.0, 500.0]
    assert main(["export", str(tmp_path / "imp1" / "commanded.csv"), "--run", str(tmp_path / "imp1"),
                 "--out", str(tmp_path / "IMP.mod")]) == 0  # was a VAL3 program for the TX200
    assert _wobj(tmp_path / "IMP.mod") == pytest.approx([1600.0, 0.0, 500.0])
    assert "robot irb6640" in (tmp_path / "IMP.mod").read_text()
    cell = tmp_path / "cell.toml"
    cell.write_text(CELL)  # the cell's tool (300 mm), sheet (1600, 0, 500) at yaw 30, robot
    (tmp_path / "b").mkdir()
    plain = _mapping(raw_cell, tmp_path / "b", "[run]\n")
    assert main(["import", "--mapping", str(plain), "--cell", str(cell), "--out", str(tmp_path / "imp2")]) == 0
    meta = json.loads((tmp_path / "imp2" / "meta.json").read_text())
    assert meta["robot"] == "irb6640" and meta["placement"] == {"origin_base_mm": [1600.0, 0.0, 500.0],
                                                                "yaw_deg": pytest.approx(30.0)}
    assert meta["tool_length_m"] == pytest.approx(0.3) and meta["cell"]["name"] == "abb-cell"
    assert "process" not in meta  # the cell declares no sheet: none recorded (the thesis's is the default)
    (tmp_path / "c").mkdir()
    sheet = tmp_path / "sheet.toml"
    sheet.write_text(CELL + '[process]\nmaterial = "AA5754-O"\nthickness_mm = 1.2\n')
    plain = _mapping(raw_cell, tmp_path / "c", "[run]\n")
    assert main(["import", "--mapping", str(plain), "--cell", str(sheet), "--out", str(tmp_path / "imp4")]) == 0
    process = json.loads((tmp_path / "imp4" / "meta.json").read_text())["process"]  # the cell's sheet, recorded
    assert process["material"] == "AA5754-O" and process["thickness_mm"] == pytest.approx(1.2)
    assert main(["import", "--mapping", str(mapping), "--robot", "kr210", "--out", str(tmp_path / "imp3")]) == 2
    err = capsys.readouterr().err
    assert "--robot gives robot 'kr210'" in err and "irb6640" in err and not (tmp_path / "imp3").exists()


def test_a_bad_run_robot_in_a_mapping_is_named(raw_cell: Path, tmp_path: Path,  # noqa: F811
                                               capsys: pytest.CaptureFixture[str]) -> None:
    mapping = _mapping(raw_cell, tmp_path, '[run]\nrobot = "irb9999"\n')
    assert main(["import", "--mapping", str(mapping), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "run.robot" in err and "irb9999" in err and "Traceback" not in err


def test_a_mapping_tool_length_over_the_cells_is_said(raw_cell: Path, tmp_path: Path,  # noqa: F811
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    cell = tmp_path / "cell.toml"
    cell.write_text(CELL)
    mapping = _mapping(raw_cell, tmp_path, "[run]\ntool_length_mm = 274.94\n")  # the example mapping's line, kept
    assert main(["import", "--mapping", str(mapping), "--cell", str(cell), "--out", str(tmp_path / "imp")]) == 0
    assert "run.tool_length_mm = 274.94 mm wins over the cell's 300 mm tool" in capsys.readouterr().err
    assert json.loads((tmp_path / "imp" / "meta.json").read_text())["tool_length_m"] == pytest.approx(0.27494)
