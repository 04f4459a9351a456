"""The cell's declared tool reaches every command that simulates the arm (issue #46): the dynamic plant (a cell's
physical tool: its tip, its mass, and the controller's IK of the command), `identify` (the Jacobian that turns K_R
into K_q) and `path`'s reach check; and the dynamic plant takes a cell's `[sensors]` under the typed `--set`."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest
from cli_refusal import refused

from twin.apps.tasks.lab_dynamic import cell_knobs
from twin.cli import main
from twin.lab.dynamic.knobs import Knobs, parse_set_args
from twin.lab.dynamic.plant import build_plant
from twin.robot.tool import ToolSpec

TOOL = ToolSpec.make(0.300, 8.0, (0.0, 0.0, 0.150))
CELL = """format = "tx200-twin-cell/1"
name = "long-tool"
robot = "tx200"
[tool]
length_mm = 300.0
mass_kg = 8.0
cog_mm = [0.0, 0.0, 150.0]
{sensors}"""


def _cell(tmp_path: Path, sensors: str = "") -> Path:
    cell = tmp_path / "cell.toml"
    cell.write_text(CELL.format(sensors=sensors))
    return cell


def test_the_dynamic_plant_carries_the_declared_tool() -> None:
    plant = build_plant(Knobs(), "tx200", TOOL)
    model, data = plant.model, mujoco.MjData(plant.model)
    mujoco.mj_kinematics(model, data)
    flange = data.site_xpos[model.site(plant.robot.flange_site).id]
    assert np.linalg.norm(data.site_xpos[plant.tcp_site] - flange) == pytest.approx(0.300, abs=1e-9)
    assert plant.tool_mass_kg == pytest.approx(8.0)  # all that hangs below the F/T sensor: the declared mass
    assert plant.tool == TOOL
    own = build_plant(Knobs(), "tx200")
    assert own.tool is None and own.tool_mass_kg < 8.0


def test_the_dynamic_load_test_of_a_longer_tool_bends_more(tmp_path: Path) -> None:
    cell = _cell(tmp_path, "[sensors]\ntracker_noise_mm = 0.0\n")
    for name, extra in (("own", []), ("cell", ["--cell", str(cell)])):
        assert main(["lab", "--plant", "dynamic", "--scenario", "loadtest", "--seed", "1", "--set",
                     "tracker_noise_mm=0", *extra, "--out", str(tmp_path / f"{name}.csv")]) == 0
    own, long_tool = (np.loadtxt(tmp_path / f"{n}.csv", delimiter=",", skiprows=1) for n in ("own", "cell"))
    assert np.array_equal(own[:, :3], long_tool[:, :3])  # the same loads
    # 25 mm more lever under an x load: the tip moves further in x (the joints' rotation times the longer arm)
    assert np.all(long_tool[:, 3] > 1.03 * own[:, 3])


def test_a_cells_sensors_reach_the_plant_under_the_typed_set(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    record = {"file": "c.toml", "name": "c", "sensors": {"ft_rate_hz": 100.0, "tracker_noise_mm": 0.05}}
    knobs = parse_set_args(cell_knobs(record, ["ft_rate_hz=250"]))
    assert knobs["ft_rate_hz"] == 250.0 and knobs["tracker_noise_mm"] == 0.05  # the typed --set wins, the rest is the cell's
    cell = _cell(tmp_path, "[sensors]\nft_noise_n = 150.0\n")  # a cell may say 150 N; the plant takes at most 100
    refused(["lab", "--plant", "dynamic", "--scenario", "loadtest", "--seed", "1", "--cell", str(cell), "--out",
             str(tmp_path / "x.csv")], capsys, str(cell), "[sensors]", "ft_noise_n", never=(tmp_path / "x.csv",))


def test_identify_turns_k_r_into_k_q_through_the_cells_tool(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    loads = tmp_path / "loads.csv"
    assert main(["lab", "--scenario", "loadtest", "--seed", "1", "--out", str(loads)]) == 0
    found = {}
    for name, extra in (("own", []), ("cell", ["--cell", str(_cell(tmp_path))])):
        capsys.readouterr()
        assert main(["identify", "--loads", str(loads), *extra, "--json", "-"]) == 0
        found[name] = np.array(json.loads(capsys.readouterr().out)["joint_stiffness_nm_per_rad"], dtype=float)
    # the same K_R through a 25 mm longer lever: joints 3 and 5 come out 9-10 % stiffer
    assert found["cell"][[2, 4]] == pytest.approx(found["own"][[2, 4]] * 1.095, rel=0.03)


def test_paths_reach_check_uses_the_cells_tool(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    reach = {}
    for name, extra in (("own", []), ("cell", ["--cell", str(_cell(tmp_path))])):
        capsys.readouterr()
        assert main(["path", "--shape", "cone", "--top-width-mm", "20", "--depth-mm", "2", *extra,
                     "--out", str(tmp_path / f"{name}.csv"), "--json", "-"]) == 0
        reach[name] = json.loads(capsys.readouterr().out)["reach"]
    assert reach["own"]["min_abs_det_j_m3"] != pytest.approx(reach["cell"]["min_abs_det_j_m3"], rel=1e-3)


def test_identify_takes_the_tools_bending_out_of_the_measured_compliance(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A Ø25 mm steel 300 mm tool bends 2.2 mm/kN at its tip: left in K_R it would make joints 1 and 5 (the ones
    a horizontal load turns) look 2.6x and 3.5x softer; taken out, they come back to the rigid tool's."""
    rigid, bending = _cell(tmp_path), tmp_path / "bending.toml"
    bending.write_text(CELL.format(sensors="").replace("[tool]\n", "[tool]\ndiameter_mm = 25.0\n"))
    k_q = {}
    for name, cell in (("rigid", rigid), ("bending", bending)):
        loads = tmp_path / f"{name}.csv"
        assert main(["lab", "--plant", "dynamic", "--scenario", "loadtest", "--seed", "1", "--cell", str(cell),
                     "--set", "tracker_noise_mm=0", "--out", str(loads)]) == 0
        for told, told_cell in (("told", cell), ("untold", rigid)):
            capsys.readouterr()
            assert main(["identify", "--loads", str(loads), "--cell", str(told_cell), "--json", "-"]) == 0
            k_q[name, told] = np.array(json.loads(capsys.readouterr().out)["joint_stiffness_nm_per_rad"])
    joints = [0, 4]
    assert k_q["bending", "told"][joints] == pytest.approx(k_q["rigid", "told"][joints], rel=0.15)
    assert np.all(k_q["bending", "untold"][joints] < 0.5 * k_q["rigid", "told"][joints])
