"""README's "Use it on your cell", walked as a new user with an ABB IRB 6640 cell (issue #46's must-show): a
300 mm / 8 kg tool, the sheet at (1600, 0, 500) mm, AA5754-O. The cell's raw exports are made by the dynamic
plant (the cell the twin does not control) and written in a tracker's and an F/T sensor's own frames and clocks
(`test_import_roundtrip.write_raw_cell`); then import, learn, compensate and export as the README types them. The
program's work object and tool are the cell's, `learn` names the robot, the tool and the sheet it fitted, and the
learned twin replays the run closer than the declared one."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from test_import_roundtrip import write_raw_cell

from twin.cli import main
from twin.runs.read import read_run

CELL = """format = "tx200-twin-cell/1"
name = "irb6640-cell"
robot = "irb6640"
[tool]
length_mm = 300.0
mass_kg = 8.0
cog_mm = [0.0, 0.0, 150.0]
[sheet]
origin_mm = [1600.0, 0.0, 500.0]
yaw_deg = 0.0
[process]
material = "AA5754-O"
thickness_mm = 1.0
"""


@pytest.mark.slow
def test_the_readme_cell_path_carries_the_irb6640_cell_to_its_program(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    Path("cell.toml").write_text(CELL)
    assert main(["path", "--shape", "cone", "--top-width-mm", "80", "--depth-mm", "15", "--cell", "cell.toml",
                 "--out", "part.csv"]) == 0
    assert main(["lab", "--plant", "dynamic", "--scenario", "nominal", "--commanded", "part.csv", "--cell",
                 "cell.toml", "--seed", "3", "--out", "plant_run"]) == 0
    mapping = write_raw_cell(read_run(Path("plant_run")), Path("cell"))  # the cell's exports, its own frames
    mapping.write_text(re.sub(r"tool_length_mm = [0-9.]+.*\n", "", mapping.read_text()))  # the cell says the tool
    capsys.readouterr()
    # the README's four commands
    assert main(["import", "--mapping", str(mapping), "--cell", "cell.toml", "--out", "runs/cell1"]) == 0
    assert "robot irb6640, sheet origin (1600, 0, 500) mm, yaw 0 deg, tool 300 mm" in capsys.readouterr().out
    assert main(["learn", "runs/cell1", "--write-model", "cell.json"]) == 0
    learned = capsys.readouterr().out
    assert "fitted for robot irb6640" in learned and "sheet origin (1600, 0, 500) mm" in learned
    assert "tool 300.00 mm" in learned and "sheet AA5754-O 1 mm" in learned
    assert "WORSE than the prior" not in learned
    before, after = (float(v) for v in re.search(r"replay runs/cell1: ([0-9.]+) mm .* -> ([0-9.]+) mm", learned).groups())
    assert after < 0.8 * before  # fitted on this run (its own replay): the learned twin is closer
    assert main(["compensate", "--method", "twin", "--model", "cell.json", "--ideal", "part.csv",
                 "--out", "compensated.csv"]) == 0
    assert "symmetry" not in capsys.readouterr().err  # a learned model uses no FE history
    assert main(["export", "compensated.csv", "--run", "runs/cell1", "--out", "ISF_PART", "--json", "-"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["robot"] == "irb6640" and record["format"] == "rapid"
    assert record["sheet_origin_in_base_mm"] == pytest.approx([1600.0, 0.0, 500.0])
    assert record["tool_length_mm"] == pytest.approx(300.0) and record["tool_mass_kg"] == pytest.approx(8.0)
    main_module = Path("ISF_PART.mod").read_text()  # with ISF_PART.pgf, the modules a RobotStudio user loads
    assert "ISF_PART.mod" in Path("ISF_PART.pgf").read_text()
    assert "PERS tooldata tIsf:=[TRUE,[[0,0,300.0000],[1,0,0,0]],[8.000,[0.0000,0.0000,150.0000]" in main_module
    assert "[[1600.0000,0.0000,500.0000]" in main_module
