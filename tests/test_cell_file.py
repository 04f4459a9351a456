"""A user's cell declared once (`--cell CELL.toml`): read and checked, laid under each command's own flags, and
recorded in the runs and programs made in it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from twin.cli import main
from twin.errors import DataFileError
from twin.process.cell_file import read_cell_file

CELL = """format = "tx200-twin-cell/1"
name = "kr210-cone"
robot = "kr210"
[tool]
length_mm = 250.0
radius_mm = 5.0
mass_kg = 3.5
cog_mm = [0.0, 0.0, 110.0]
[sheet]
origin_mm = [1700.0, 0.0, 450.0]
yaw_deg = 0.0
[process]
material = "AA5754-O"
thickness_mm = 1.0
[sensors]
tracker_rate_hz = 100.0
ft_rate_hz = 50.0
"""


def _cell(tmp_path: Path, text: str = CELL, name: str = "cell.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_cell_file_is_read_with_every_part(tmp_path: Path) -> None:
    cell = read_cell_file(_cell(tmp_path))
    assert (cell.name, cell.robot, cell.origin_mm, cell.yaw_deg) == ("kr210-cone", "kr210", (1700.0, 0.0, 450.0), 0.0)
    assert (cell.tool.length_mm, cell.tool.mass_kg, cell.tool.cog_mm) == (250.0, 3.5, (0.0, 0.0, 110.0))
    assert cell.process.tool_radius_m == pytest.approx(5e-3) and cell.process.thickness_m == pytest.approx(1e-3)
    assert cell.process.material is not None and cell.process.material.name == "AA5754-O"
    record = cell.record()
    assert record["name"] == "kr210-cone" and record["tool"]["length_mm"] == 250.0
    assert Path(record["file"]).is_absolute()


@pytest.mark.parametrize(("change", "message"), [
    (('format = "tx200-twin-cell/1"', 'format = "tx200-twin-process/1"'), "expected 'tx200-twin-cell/1'"),
    (("[sheet]", "[sheet]\nheight_mm = 3"), "unknown key(s) ['sheet.height_mm']"),
    (("length_mm = 250.0", "length_mm = 15000.0"), "tool.length_mm = 15000.0: expected 20 to 1500 mm"),
    (("mass_kg = 3.5", 'mass_kg = "heavy"'), "tool.mass_kg = 'heavy': expected a number"),
    (("origin_mm = [1700.0, 0.0, 450.0]", "origin_mm = [1700.0, 0.0]"), "sheet.origin_mm"),
    (("thickness_mm = 1.0", "thickness_mm = 1.0\ntool_radius_mm = 6.0"), "both give the tool's radius"),
    (('robot = "kr210"', 'robot = "mine.xml"'), "no such file"),
    (("[process]", "[process]\nstrength = 3"), "unknown key(s) ['process.strength']"),
    (("ft_rate_hz = 50.0", "ft_rate_hz = 0.0"), "sensors.ft_rate_hz = 0.0: expected 1 to 10000 Hz"),
])
def test_a_bad_cell_file_is_refused_naming_the_file_and_the_key(tmp_path: Path, change: tuple[str, str],
                                                                message: str, capsys: pytest.CaptureFixture[str]) -> None:
    path = _cell(tmp_path, CELL.replace(*change))
    with pytest.raises(DataFileError, match=None) as caught:
        read_cell_file(path)
    assert message in str(caught.value) and str(path) in str(caught.value)
    out = tmp_path / "p.csv"
    assert main(["path", "--shape", "cone", "--cell", str(path), "--out", str(out)]) == 2  # the CLI: exit 2
    assert message in capsys.readouterr().err and not out.exists()


def test_the_cell_is_laid_under_the_flags_and_recorded(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cell = _cell(tmp_path)
    path = tmp_path / "cone.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "20", "--depth-mm", "3", "--cell", str(cell),
                 "--out", str(path)]) == 0
    assert "modelled tool" not in capsys.readouterr().err  # `path` checks the reach with the cell's tool
    assert main(["lab", "--scenario", "nominal", "--seed", "1", "--commanded", str(path), "--cell", str(cell),
                 "--material", "AA1050-O", "--out", str(tmp_path / "run")]) == 0
    meta = json.loads((tmp_path / "run" / "meta.json").read_text())
    assert meta["robot"] == "kr210" and meta["placement"]["origin_base_mm"] == [1700.0, 0.0, 450.0]
    assert meta["process"]["material"] == "AA1050-O"  # the flag wins over the cell
    assert meta["process"]["tool_radius_mm"] == 5.0 and meta["cell"]["name"] == "kr210-cone"
    tracker = (tmp_path / "run" / "tracker.csv").read_text().splitlines()
    assert float(tracker[2].split(",")[0]) == pytest.approx(0.01)  # the cell's 100 Hz tracker
    capsys.readouterr()
    assert main(["export", str(path), "--cell", str(cell), "--origin-mm", "1650", "0", "450",
                 "--out", str(tmp_path / "ISF.src"), "--json", "-"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert (record["tool_length_mm"], record["tool_mass_kg"]) == (250.0, 3.5)
    assert record["sheet_origin_in_base_mm"] == pytest.approx([1650.0, 0.0, 450.0])  # the flag wins
    assert "the cell kr210-cone" in record["tool_and_base_from"] and record["cell"]["robot"] == "kr210"
    src = (tmp_path / "ISF.src").read_text()  # the cell's tool, load and centre of gravity in the controller's data
    assert "TOOL_DATA[16]={X 0.0000,Y 0.0000,Z 250.0000" in src
    assert "LOAD_DATA[16]={M 3.500,CM {X 0.0000,Y 0.0000,Z 110.0000" in src


def test_the_example_cell_file_is_valid() -> None:
    cell = read_cell_file(Path(__file__).resolve().parents[1] / "docs" / "examples" / "cell.toml")
    assert cell.robot == "kr210" and cell.tool.length_mm == 250.0
