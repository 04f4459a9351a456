"""The twin simulates the declared tool's own bending and the F/T sensor's mount (issue #46): a cell's shank (or
measured tip stiffness) bends the tool as a cantilever clamped at the flange, in the quasi-static twin, `info` and
the dynamic plant; a cell's `[ft_sensor]` turns an import's sensor axes; no bending declared is the model as it was."""

from __future__ import annotations

import json
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
from test_import_mapping import cell as raw_cell  # noqa: F401  (the synthetic cell's raw exports and mapping)

from twin.analysis.tool_choice import resolve_tool_spec
from twin.cli import main
from twin.errors import DataFileError, InputError
from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.plant import build_plant
from twin.process.cell_file import read_cell_file
from twin.robot.description import load_robot
from twin.robot.ft_mount import rpy_matrix, sensor_in_sheet
from twin.robot.model import build_model
from twin.robot.tool import ToolSpec
from twin.robot.tool_bending import (
    BENDING_DAMPING_RATIO,
    bending_dofs,
    cantilever_tip_stiffness,
    damp_bending,
)
from twin.runs.importer import with_cell
from twin.runs.mapping import load_mapping
from twin.sim.model_file import read_model_file, write_model_file
from twin.sim.spec import TwinSpec

CELL = """format = "tx200-twin-cell/1"
name = "bending-tool"
robot = "tx200"
[tool]
length_mm = 300.0
mass_kg = 8.0
cog_mm = [0.0, 0.0, 150.0]
{bending}
"""
#: A Ø25 mm steel shank, 300 mm: k = 3EI/L³ = 447 N/mm (EI = 4026 N·m²).
K_25 = cantilever_tip_stiffness(0.025, 210e9, 0.300)
RIGID = ToolSpec.make(0.300, 8.0, (0.0, 0.0, 0.150))
BENT = RIGID._replace(bending_stiffness_n_per_m=K_25)


def _cell(tmp_path: Path, bending: str = "", name: str = "cell.toml") -> Path:
    path = tmp_path / name
    path.write_text(CELL.format(bending=bending))
    return path


def test_the_cantilever_stiffness_is_3ei_over_l_cubed() -> None:
    ei = 210e9 * math.pi * 0.025**4 / 64.0
    assert pytest.approx(3.0 * ei / 0.3**3, rel=1e-12) == K_25
    assert pytest.approx(447.4, abs=0.1) == K_25 / 1e3  # [N/mm]: 0.67 mm at 300 N
    with pytest.raises(InputError, match="diameter_m"):
        cantilever_tip_stiffness(-0.01, 210e9, 0.3)


def test_a_cells_shank_or_measured_stiffness_reaches_the_tool(tmp_path: Path) -> None:
    robot = load_robot("tx200")
    shank = read_cell_file(_cell(tmp_path, "diameter_mm = 25.0")).record()
    assert resolve_tool_spec(robot, cell=shank) == BENT  # E defaults to steel's 210 GPa
    alu = read_cell_file(_cell(tmp_path, "diameter_mm = 25.0\nyoungs_modulus_gpa = 70.0")).record()
    assert resolve_tool_spec(robot, cell=alu).bending_stiffness_n_per_m == pytest.approx(K_25 / 3.0, rel=1e-12)
    measured = read_cell_file(_cell(tmp_path, "bending_stiffness_n_per_mm = 500.0")).record()
    assert resolve_tool_spec(robot, cell=measured).bending_stiffness_n_per_m == 5e5
    assert resolve_tool_spec(robot, cell=read_cell_file(_cell(tmp_path)).record()) == RIGID  # none: rigid
    # a model file keeps it; the cell wins over it (one precedence)
    model = write_model_file(tmp_path / "m.json", TwinSpec(tool=BENT))
    back = read_model_file(model).tool
    assert back is not None and back.bending_stiffness_n_per_m == pytest.approx(K_25, rel=1e-12)
    assert json.loads(model.read_text())["tool"]["bending_stiffness_n_per_mm"] == pytest.approx(447.41, abs=0.01)
    assert resolve_tool_spec(robot, cell=measured, model=back).bending_stiffness_n_per_m == 5e5


@pytest.mark.parametrize(("bending", "words"), [
    ("diameter_mm = 0.5", ["tool.diameter_mm", "0.5", "2 to 150 mm"]),
    ("diameter_mm = 25.0\nbending_stiffness_n_per_mm = 400.0", ["tool.diameter_mm", "bending_stiffness", "keep one"]),
    ("youngs_modulus_gpa = 210.0", ["tool.youngs_modulus_gpa", "without tool.diameter_mm"]),
    ("diameter_mm = 25.0\nyoungs_modulus_gpa = 210000.0", ["tool.youngs_modulus_gpa", "1 to 1000 GPa"]),
    ("bending_stiffness_n_per_mm = \"stiff\"", ["tool.bending_stiffness_n_per_mm", "expected a number"]),
    ("[ft_sensor]\nrotation_deg = 400.0", ["ft_sensor.rotation_deg", "-360 to 360 deg"]),
    ("[ft_sensor]\nrotation_deg = 90.0\nrpy_deg = [0, 0, 90]", ["rotation_deg", "rpy_deg", "keep one"]),
    ("[ft_sensor]\nrpy_deg = [0, 90]", ["ft_sensor.rpy_deg", "three angles"]),
    ("[ft_sensor]\ntilt_deg = 3.0", ["ft_sensor.tilt_deg"]),
])
def test_bad_bending_and_mount_keys_are_named(tmp_path: Path, bending: str, words: list[str]) -> None:
    path = _cell(tmp_path, bending)
    with pytest.raises(DataFileError) as caught:
        read_cell_file(path)
    for word in [str(path), *words]:
        assert word in str(caught.value)
    with pytest.raises(InputError, match="positive stiffness"):
        ToolSpec.make(0.3, bending_stiffness_n_per_m=-1.0)


def test_no_bending_declared_is_the_model_and_the_twin_as_before() -> None:
    robot = load_robot("tx200")
    plain, bent = build_model(robot, tool=RIGID), build_model(robot, tool=BENT)
    assert plain.nv == robot.dof and bent.nv == robot.dof + 2 and bending_dofs(plain).size == 0
    assert RIGID.rigid is RIGID or RIGID.rigid == RIGID
    assert "bending_stiffness_n_per_mm" not in RIGID.to_json()
    twin = TwinSpec(tool=RIGID).build()
    assert twin.model.nv == robot.dof and twin._stiffness_diag().size == robot.dof
    np.testing.assert_array_equal(twin._stiffness_diag(), twin.joint_stiffness)
    # the arm is the same: the tip, the gravity load and all that hangs below the flange, hinges at 0
    for model in (plain, bent):
        data = mujoco.MjData(model)
        data.qpos[robot.addresses(model).qpos] = robot.q_home
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        g = np.zeros(model.nv)
        mujoco.mj_rne(model, data, 0, g)
        if model is plain:
            tip0, g0 = data.site_xpos[model.site(robot.tool_site).id].copy(), g.copy()
    np.testing.assert_allclose(data.site_xpos[bent.site(robot.tool_site).id], tip0, atol=1e-12)
    np.testing.assert_allclose(g[: robot.dof], g0, rtol=1e-12, atol=1e-9)
    assert bent.body_subtreemass[bent.body("ft_sensor").id] == pytest.approx(8.0)


def test_info_compliance_grows_by_l3_over_3ei_in_x_and_y(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = {}
    for name, bending in (("rigid", ""), ("bent", "diameter_mm = 25.0")):
        assert main(["info", "--cell", str(_cell(tmp_path, bending, f"{name}.toml")), "--json", "-"]) == 0
        out[name] = json.loads(capsys.readouterr().out)
    grown = np.diag(out["bent"]["compliance_home_mm_per_kn"]) - np.diag(out["rigid"]["compliance_home_mm_per_kn"])
    expected = 1e6 / K_25  # L³/(3EI) [mm/kN]: 2.235
    assert grown[:2] == pytest.approx([expected, expected], rel=0.02)
    assert abs(grown[2]) < 0.001 * expected  # along the tool axis: nothing
    assert out["bent"]["tool"]["bending_stiffness_n_per_mm"] == pytest.approx(K_25 / 1e3)


def test_the_twin_deflects_by_f_over_k_more_and_the_sensor_reads_the_same() -> None:
    rigid, bent = TwinSpec(tool=RIGID).build(), TwinSpec(tool=BENT).build()
    assert bent.kinematics.model.nv == rigid.model.nv  # the IK's tool is rigid
    f = np.array([300.0, -200.0, -500.0])  # base frame [N]
    extra = bent.static_deflection(f) - rigid.static_deflection(f)
    np.testing.assert_allclose(extra[:2], f[:2] / K_25, rtol=0.03)  # 0.67 mm, -0.45 mm
    assert abs(extra[2]) < 0.01 * np.linalg.norm(f[:2]) / K_25
    # along a short stroke on the sheet: the tip lags F_xy / k more, and the F/T sensor above the bending reads
    # the sheet's force as the rigid tool's does
    t = np.linspace(0.0, 2.0, 41)
    p = np.column_stack([np.linspace(0.0, 0.02, 41), np.zeros(41), np.full(41, -0.002)])
    runs = [twin.simulate(t, p) for twin in (rigid, bent)]
    f_in_plane = runs[1].f_sheet_n[-1, :2]
    lag = (runs[1].p_sheet_m - runs[1].p_unloaded_sheet_m) - (runs[0].p_sheet_m - runs[0].p_unloaded_sheet_m)
    assert np.linalg.norm(f_in_plane) > 50.0
    np.testing.assert_allclose(lag[-1, :2], f_in_plane / K_25, rtol=0.1, atol=5e-6)
    for twin, run in zip((rigid, bent), runs, strict=True):
        np.testing.assert_allclose(twin.sensor_forces(run, t[5:]), run.force_at(t[5:]), atol=1e-6)


def test_the_dynamic_plant_bends_damped_and_stays_stable_at_1_ms() -> None:
    plant = build_plant(Knobs(), "tx200", BENT)
    dofs = bending_dofs(plant.model)
    assert dofs.size == 2 and plant.tool_mass_kg == pytest.approx(8.0)
    k_theta = K_25 * 0.3**2
    np.testing.assert_allclose(plant.model.jnt_stiffness[plant.model.dof_jntid[dofs]], k_theta)
    data = mujoco.MjData(plant.model)
    mujoco.mj_forward(plant.model, data)
    M = np.zeros((plant.model.nv, plant.model.nv))
    mujoco.mj_fullM(plant.model, data, M)
    ratio = plant.model.dof_damping[dofs] / (2.0 * np.sqrt(k_theta * M[dofs, dofs]))
    np.testing.assert_allclose(ratio, BENDING_DAMPING_RATIO, rtol=1e-9)
    # a stiff stub (1e6 N/mm) would ring above the step's reach: armature slows it to ω·dt = 1
    stiff = build_plant(Knobs(), "tx200", RIGID._replace(bending_stiffness_n_per_m=1e9))
    info = damp_bending(stiff.model, 1e-3)
    assert info["mode_hz"] > 500.0 and info["mode_kept_hz"] == pytest.approx(1e3 / (2 * math.pi), rel=1e-6)
    # held at rest with the tip pushed sideways, the 1 ms step settles (no blow-up)
    for p in (plant, stiff):
        m, d = p.model, mujoco.MjData(p.model)
        d.qpos[p.motor_qpos] = p.robot.q_home
        d.ctrl[:] = p.robot.q_home
        tool = p.tool_body
        for _ in range(500):
            d.xfrc_applied[tool, :3] = (300.0, 0.0, 0.0)
            mujoco.mj_step(m, d)
        assert np.all(np.isfinite(d.qpos)) and np.abs(d.qvel[bending_dofs(m)]).max() < 1.0


def test_the_dynamic_load_test_bends_by_f_over_k(tmp_path: Path) -> None:
    for name, bending in (("rigid", ""), ("bent", "diameter_mm = 25.0")):
        cell = _cell(tmp_path, bending + "\n[sensors]\ntracker_noise_mm = 0.0", f"{name}.toml")
        assert main(["lab", "--plant", "dynamic", "--scenario", "loadtest", "--seed", "1", "--cell", str(cell),
                     "--out", str(tmp_path / f"{name}.csv")]) == 0
    rigid, bent = (np.loadtxt(tmp_path / f"{n}.csv", delimiter=",", skiprows=1) for n in ("rigid", "bent"))
    extra = bent[:, 3:6] - rigid[:, 3:6]  # [mm]
    np.testing.assert_allclose(extra[:, :2], rigid[:, :2] / K_25 * 1e3, rtol=0.06)
    assert np.abs(extra[:, 2]).max() < 0.05


def test_an_import_takes_the_cells_sensor_mount_under_the_mappings_own(raw_cell: Path, tmp_path: Path) -> None:  # noqa: F811
    mount = {"rpy_deg": [0.0, 0.0, 90.0], "offset_mm": [0.0, 0.0, 30.0]}
    cell = {"file": "c.toml", "name": "c", "robot": "kr210", "sheet": {"yaw_deg": 30.0}, "ft_sensor": mount}
    mapping = load_mapping(raw_cell)
    assert not mapping.sensor_rotation_given
    np.testing.assert_array_equal(with_cell(mapping).sensor.R_sheet_sensor, np.eye(3))  # no mount: the sheet's axes
    R = with_cell(mapping, cell=cell).sensor.R_sheet_sensor
    np.testing.assert_allclose(R, sensor_in_sheet("kr210", (0.0, 0.0, 90.0), 30.0), atol=1e-12)
    # the KR 210 holds the tool down with the flange x along −x of the base: z down, the 90° turn and the yaw
    np.testing.assert_allclose(R, rpy_matrix((0, 0, -30)) @ np.diag([-1.0, 1.0, -1.0]) @ rpy_matrix((0, 0, 90)),
                               atol=1e-9)
    own = tmp_path / "own.toml"
    own.write_text(raw_cell.read_text() + "\n[forces.sensor]\nR_sheet_sensor = [[0, 1, 0], [-1, 0, 0], [0, 0, 1]]\n")
    for name in ("cmd.csv", "tracker.csv", "forces.csv"):
        (tmp_path / name).write_bytes((raw_cell.parent / name).read_bytes())
    given = with_cell(load_mapping(own), cell=cell).sensor.R_sheet_sensor
    np.testing.assert_array_equal(given, [[0, 1, 0], [-1, 0, 0], [0, 0, 1]])  # the mapping's own key wins


def test_a_compensated_command_for_a_bending_tool_leads_by_f_over_k(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from twin.analysis.resolve import resolve_spec

    commands = {}
    for name, bending in (("rigid", ""), ("bent", "diameter_mm = 25.0")):
        cell = _cell(tmp_path, bending, f"{name}.toml")
        assert main(["compensate", "--method", "twin", "--cell", str(cell), "--out", str(tmp_path / f"{name}.csv")]) == 0
        commands[name] = np.loadtxt(tmp_path / f"{name}.csv", delimiter=",", skiprows=1, comments="#")
    assert "over-corrects" not in capsys.readouterr().err  # its gain is measured with the tool's bending too
    bent = commands["bent"]
    spec = resolve_spec(cell=read_cell_file(tmp_path / "bent.toml").record())
    f = spec.build().simulate(bent[:, 0], bent[:, 1:] / 1e3).f_sheet_n
    lead = bent[:, 1] - commands["rigid"][:, 1]  # [mm]
    expected = -f[:, 0] / K_25 * 1e3  # the command leads against F_x by F_x L³/(3EI): ~1.4 mm at 640 N
    loaded = np.abs(f[:, 0]) > 0.5 * np.abs(f[:, 0]).max()
    assert np.vdot(lead[loaded], expected[loaded]) / np.vdot(expected[loaded], expected[loaded]) == \
        pytest.approx(1.0, abs=0.05)


def test_the_online_correction_takes_the_tools_bending() -> None:
    """The online compensator corrects the tool's own bending too (a constant compliance at the tip while the tool
    is held down): a steady in-plane force moves its correction by F / k more than the rigid tool's."""
    from twin.robot.kinematics import Kinematics
    from twin.sim.online import OnlineCompensator, OnlineSettings
    from twin.sim.spec import TwinSpec

    f_n = np.array([300.0, -100.0, 0.0])  # in-plane (the tool stands 6 mrad off vertical at home: an axial force
    # would add 0.6 % of itself across it)
    k = K_25  # a Ø25 mm steel 300 mm tool [N/m]
    out = {}
    q = Kinematics().q_home
    for name, tool in (("rigid", ToolSpec.make(0.3, 8.0)),
                       ("bending", ToolSpec.make(0.3, 8.0, bending_stiffness_n_per_m=k))):
        comp = OnlineCompensator(TwinSpec(tool=tool), OnlineSettings(max_rate_mm_s=1000.0))
        for i in range(500):
            comp.step(0.004 * i, 0.004 * i, f_n, q)
        out[name] = comp.correction_m.copy()
    extra = out["bending"] - out["rigid"]
    np.testing.assert_allclose(extra[:2], -f_n[:2] / k, rtol=0.02)  # across the tool: F / k
    assert abs(extra[2]) < 0.01 * np.linalg.norm(extra[:2])  # along it: only the 6 mrad tilt's share
