"""The user's declared tool is simulated (issue #46): `TwinSpec.tool` moves the tool tip site and the tool's mass in
the compiled model, a `--cell`'s tool reaches the twin, model files keep it, and no tool declared is the robot model
as it was."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from twin.analysis.resolve import resolve_spec
from twin.analysis.tool_choice import resolve_tool_spec
from twin.cli import main
from twin.errors import DataFileError, InputError
from twin.robot.description import load_robot
from twin.robot.kinematics import Kinematics
from twin.robot.model import build_model, load_model
from twin.robot.tool import ToolSpec
from twin.sim.model_file import model_payload, read_model_file, write_model_file
from twin.sim.spec import TwinSpec

TOOL = ToolSpec.make(0.300, 8.0, (0.0, 0.0, 0.150))
CELL = """format = "tx200-twin-cell/1"
name = "long-tool"
robot = "{robot}"
[tool]
length_mm = 300.0
mass_kg = 8.0
cog_mm = [0.0, 0.0, 150.0]
"""


def _home(model: mujoco.MjModel, robot_name: str) -> tuple[mujoco.MjData, np.ndarray, np.ndarray]:
    """Data at home, the flange and tool tip positions [m]."""
    robot = load_robot(robot_name)
    data = mujoco.MjData(model)
    data.qpos[robot.addresses(model).qpos] = robot.q_home
    mujoco.mj_forward(model, data)
    return data, data.site_xpos[model.site(robot.flange_site).id].copy(), \
        data.site_xpos[model.site(robot.tool_site).id].copy()


def _gravity(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    out = np.zeros(model.nv)
    mujoco.mj_rne(model, data, 0, out)
    return out


@pytest.mark.parametrize("name", ["tx200", "irb6640"])
def test_the_declared_tool_moves_the_tip_by_the_length_difference(name: str) -> None:
    robot = load_robot(name)
    plain, declared = build_model(robot), build_model(robot, tool=ToolSpec.make(0.300))
    d0, flange0, tip0 = _home(plain, name)
    _, flange1, tip1 = _home(declared, name)
    np.testing.assert_array_equal(flange1, flange0)  # the arm is the same
    axis = d0.site_xmat[plain.site(robot.flange_site).id].reshape(3, 3)[:, 2]  # the flange z
    np.testing.assert_allclose(tip1 - tip0, (0.300 - robot.tool_length_m) * axis, atol=1e-12)
    assert np.linalg.norm(tip1 - flange1) == pytest.approx(0.300, abs=1e-12)
    np.testing.assert_array_equal(declared.body_mass, plain.body_mass)  # a length alone keeps the masses


@pytest.mark.parametrize("name", ["tx200", "irb6640"])
def test_the_compliance_at_the_tip_grows_with_the_longer_tool(name: str) -> None:
    robot = load_robot(name)
    c_model = Kinematics(build_model(robot), robot=robot).compliance(robot.q_home)
    c_long = Kinematics(build_model(robot, tool=TOOL), robot=robot).compliance(robot.q_home)
    assert np.linalg.norm(c_long) > 1.02 * np.linalg.norm(c_model)  # 25 mm more lever on the wrist springs
    assert np.linalg.eigvalsh(c_long).max() > np.linalg.eigvalsh(c_model).max()


@pytest.mark.parametrize("name", ["tx200", "irb6640"])
def test_an_8_kg_tool_loads_joints_2_and_3_more(name: str) -> None:
    robot = load_robot(name)
    light, heavy = build_model(robot, tool=ToolSpec.make(0.300)), build_model(robot, tool=TOOL)
    g_light, g_heavy = _gravity(light, _home(light, name)[0]), _gravity(heavy, _home(heavy, name)[0])
    assert np.all(np.abs(g_heavy[1:3]) > np.abs(g_light[1:3]) + 10.0)  # 3.3 kg more at ~1 m: tens of N·m
    # all that hangs below the flange is the declared 8 kg (the F/T sensor's mass included)
    flange_body = light.site_bodyid[light.site(robot.flange_site).id]
    below = heavy.body_subtreemass[flange_body] - heavy.body_mass[flange_body]
    assert below == pytest.approx(8.0, abs=1e-12)
    tool_body = heavy.site_bodyid[heavy.site(robot.tool_site).id]
    data, flange, _ = _home(heavy, name)
    R = data.site_xmat[heavy.site(robot.flange_site).id].reshape(3, 3)
    np.testing.assert_allclose(R.T @ (data.xipos[tool_body] - flange), [0.0, 0.0, 0.150], atol=1e-12)  # its CoG


def test_no_tool_declared_is_exactly_the_old_model() -> None:
    robot = load_robot()
    twin = TwinSpec().build()
    plain = load_model(robot=robot)  # the MJCF as it is
    for q in (robot.q_home, robot.q_home + 0.1):
        p_twin, R_twin = twin.kinematics.fk(q)
        p_plain, R_plain = Kinematics(plain, robot=robot).fk(q)
        np.testing.assert_array_equal(p_twin, p_plain)
        np.testing.assert_array_equal(R_twin, R_plain)
        np.testing.assert_array_equal(twin.kinematics.compliance(q), Kinematics(plain, robot=robot).compliance(q))
    np.testing.assert_array_equal(twin.model.body_mass, plain.body_mass)
    np.testing.assert_array_equal(twin.model.site_pos, plain.site_pos)
    assert TwinSpec().tool is None and TwinSpec().tool_length_m == robot.tool_length_m
    # a tool the robot's own length and no mass is no tool: the run's and cell's records of the model's tool
    assert resolve_tool_spec(robot, cell={"tool": {"length_mm": 1e3 * robot.tool_length_m}}) is None


def test_a_bad_tool_is_refused() -> None:
    for args, message in (((-0.3,), "positive length"), ((0.3, -1.0), "non-negative mass"),
                          ((0.3, None, (0, 0, 0.1)), "needs the tool's mass"), ((float("nan"),), "finite")):
        with pytest.raises(InputError, match=message):
            ToolSpec.make(*args)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"TwinSpec\.tool"):
        TwinSpec(tool=(0.3, 8.0))  # type: ignore[arg-type]


def test_a_model_file_round_trips_the_tool(tmp_path: Path) -> None:
    spec = TwinSpec(tool=TOOL)
    path = write_model_file(tmp_path / "m.json", spec)
    assert json.loads(path.read_text())["tool"] == {"length_mm": 300.0, "mass_kg": 8.0, "cog_mm": [0.0, 0.0, 150.0]}
    back = read_model_file(path)
    assert back.tool == TOOL and back.tool_length_m == 0.3
    assert "tool" not in model_payload(TwinSpec())  # no tool declared: none written
    assert read_model_file(write_model_file(tmp_path / "plain.json", TwinSpec())).tool is None
    payload = model_payload(spec)
    payload["tool"]["weight_kg"] = 8.0
    (tmp_path / "bad.json").write_text(json.dumps(payload))
    with pytest.raises(DataFileError, match=r"tool\.weight_kg"):
        read_model_file(tmp_path / "bad.json")
    payload["tool"] = {"length_mm": 15000.0}
    (tmp_path / "long.json").write_text(json.dumps(payload))
    with pytest.raises(DataFileError, match="tool length"):
        read_model_file(tmp_path / "long.json")


def test_the_cell_tool_reaches_the_twin_below_the_run_and_over_the_model_file(tmp_path: Path) -> None:
    cell = {"name": "long-tool", "file": "c.toml", "tool": {"length_mm": 300.0, "mass_kg": 8.0,
                                                             "cog_mm": [0.0, 0.0, 150.0]}}
    assert resolve_spec(cell=cell).tool == TOOL
    model = write_model_file(tmp_path / "m.json", TwinSpec(tool=ToolSpec.make(0.28, 5.0)))
    assert resolve_spec(model=model).tool == ToolSpec.make(0.28, 5.0)  # the model file's
    assert resolve_spec(model=model, cell=cell).tool == TOOL  # the cell over the model file
    assert resolve_spec(cell={"tool": {"length_mm": 290.0}}).tool == ToolSpec.make(0.29)


def test_info_and_compensate_simulate_the_cells_tool(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cell = tmp_path / "cell.toml"
    cell.write_text(CELL.format(robot="tx200"))
    assert main(["info", "--json", "-"]) == 0
    plain = json.loads(capsys.readouterr().out)
    assert main(["info", "--cell", str(cell), "--json", "-"]) == 0
    declared = json.loads(capsys.readouterr().out)
    assert declared["tool"] == {"length_mm": 300.0, "mass_kg": 8.0, "from": "the cell"}
    # the tool points down at home to within a milliradian: the tip is 25.06 mm lower
    assert declared["tcp_home_m"][2] == pytest.approx(plain["tcp_home_m"][2] - (0.300 - 0.27494), abs=1e-5)
    assert np.linalg.norm(declared["compliance_home_mm_per_kn"]) > np.linalg.norm(plain["compliance_home_mm_per_kn"])
    assert main(["compensate", "--method", "twin", "--cell", str(cell), "--out", str(tmp_path / "c.csv")]) == 0
    assert "modelled tool" not in capsys.readouterr().err  # the tool is simulated: no note that it is not
    assert main(["compensate", "--method", "twin", "--out", str(tmp_path / "d.csv")]) == 0
    long_tool = np.loadtxt(tmp_path / "c.csv", delimiter=",", skiprows=1, comments="#")
    model_tool = np.loadtxt(tmp_path / "d.csv", delimiter=",", skiprows=1, comments="#")
    assert 0.02 < np.abs(long_tool[:, 1:] - model_tool[:, 1:]).max() < 0.5  # [mm]: the longer tool yields more


def test_a_lab_run_with_a_declared_tool_records_it_and_its_replay_simulates_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from twin.runs.read import read_run

    cell = tmp_path / "cell.toml"
    cell.write_text(CELL.format(robot="tx200"))
    path = tmp_path / "cone.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "20", "--depth-mm", "2", "--cell", str(cell),
                 "--out", str(path)]) == 0
    assert "modelled tool" not in capsys.readouterr().err  # `path` checks the reach of the cell's tool
    assert main(["lab", "--scenario", "nominal", "--seed", "1", "--commanded", str(path), "--cell", str(cell),
                 "--out", str(tmp_path / "run")]) == 0
    assert "modelled tool" not in capsys.readouterr().err  # the quasi-static lab's plant is the twin: simulated
    meta = json.loads((tmp_path / "run" / "meta.json").read_text())
    assert meta["tool_length_m"] == 0.3 and meta["cell"]["tool"]["mass_kg"] == 8.0
    run = read_run(tmp_path / "run")
    assert resolve_spec(run=run).tool == TOOL  # the run's record: its tool length and its cell's mass
    assert resolve_spec(run=run, cell={"tool": {"length_mm": 250.0}}).tool == TOOL  # the run over a cell
