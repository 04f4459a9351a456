"""The MJCF robot and the cell scene: they load, step stably, and hold the thesis's numbers."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from twin.analysis.identify.default_stiffness import thesis_stiffness_fit
from twin.base.resources import models_dir
from twin.errors import ModelError
from twin.robot.description import load_robot
from twin.robot.model import load_model

# Staubli datasheet D181.573.04 joint ranges [deg]
RANGES_DEG = [(-180, 180), (-120, 120), (-140, 145), (-270, 270), (-120, 120), (-270, 270)]
HOME_TABLE_4_1_DEG = [-0.08, 38.03, 90.62, -0.33, 51.72, -7.91]  # thesis Table 4.1
HOME_Q_RAD = load_robot().q_home
TOOL_LENGTH_M = load_robot().tool_length_m


@pytest.fixture(scope="module")
def scene() -> mujoco.MjModel:
    return load_model(scene=True)


@pytest.fixture(scope="module")
def robot() -> mujoco.MjModel:
    return load_model(scene=False)


def _warnings(data: mujoco.MjData) -> list[int]:
    return [int(w.number) for w in data.warning]


@pytest.mark.parametrize("path", [load_robot().mjcf, load_robot().scene], ids=["robot", "scene"])
def test_model_loads_and_home_is_clean(path: Path) -> None:
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    assert sum(_warnings(data)) == 0
    assert data.ncon == 0, "no contact (robot self-contact or with the cell) at home"
    assert model.nq == 6 and model.nu == 6


def test_scene_resolves_robot_and_cell_meshes(scene: mujoco.MjModel) -> None:
    names = {scene.mesh(i).name for i in range(scene.nmesh)}
    assert names == {"base", "link1", "link2", "link3", "link4", "link5", "link6", "clamp_ring"}
    assert np.all(scene.mesh_vertnum > 0)


def test_scene_steps_stably_with_noisy_ctrl_around_home(scene: mujoco.MjModel) -> None:
    data = mujoco.MjData(scene)
    mujoco.mj_resetDataKeyframe(scene, data, scene.key("home").id)
    assert scene.opt.timestep == pytest.approx(0.002)
    rng = np.random.default_rng(1234)
    for _ in range(500):  # 1 s
        data.ctrl[:] = HOME_Q_RAD + rng.normal(0.0, 0.01, 6)
        mujoco.mj_step(scene, data)
    assert sum(_warnings(data)) == 0
    assert np.all(np.isfinite(data.qpos))
    # stiff joints: the arm stays within gravity sag + noise of the command
    assert np.max(np.abs(data.qpos - HOME_Q_RAD)) < 0.05


def test_home_keyframe_is_table_4_1(robot: mujoco.MjModel) -> None:
    key = robot.key("home")
    np.testing.assert_allclose(key.qpos, np.deg2rad(HOME_TABLE_4_1_DEG), atol=1e-15)
    np.testing.assert_array_equal(key.ctrl, key.qpos)


def test_robot_description_reads_home_from_the_keyframe_as_table_4_1() -> None:
    robot = load_robot()
    assert robot.home_keyframe == "home"
    np.testing.assert_allclose(robot.q_home_rad, np.deg2rad(HOME_TABLE_4_1_DEG), rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(robot.q_home, np.deg2rad(HOME_TABLE_4_1_DEG), rtol=0.0, atol=1e-12)


def test_robot_description_tool_length_is_thesis_3_2_1() -> None:
    assert load_robot().tool_length_m == pytest.approx(0.27494, abs=1e-12)


def test_stiffness_priors_are_the_rounded_thesis_fit() -> None:
    robot = load_robot()
    fit = thesis_stiffness_fit()
    priors = {p.joint: p.k_nm_per_rad for p in robot.stiffness_priors}
    for joint in ("joint1", "joint2", "joint3", "joint5"):
        i = robot.joints.index(joint)
        assert priors[joint] == pytest.approx(fit.K_q[i], rel=5e-3), joint


def _bad_description(tmp_path: Path, text: str) -> Path:
    """The shipped description with `text` edited in, pointing at the shipped MJCF by absolute path."""
    robot = load_robot()
    out = tmp_path / "bad_robot.toml"
    text = text.replace('mjcf = "tx200.xml"', f'mjcf = "{robot.mjcf.resolve()}"')
    text = re.sub(r'^scene = .*$', "", text, flags=re.MULTILINE)
    out.write_text(text, encoding="utf-8")
    return out


def test_description_without_joints_table_raises_model_error_naming_the_file(tmp_path: Path) -> None:
    text = load_robot().source.read_text(encoding="utf-8")
    text = re.sub(r"^\[joints\]\n(?:(?!\[).*\n)*", "", text, flags=re.MULTILINE)
    assert "[joints]" not in text
    bad = _bad_description(tmp_path, text)
    with pytest.raises(ModelError, match=re.escape(str(bad))) as info:
        load_robot(bad)
    assert "joints" in str(info.value)


def test_description_naming_a_joint_the_mjcf_lacks_raises_model_error_naming_the_file(tmp_path: Path) -> None:
    text = load_robot().source.read_text(encoding="utf-8").replace('"joint6"]', '"joint7"]', 1)
    assert '"joint7"' in text
    bad = _bad_description(tmp_path, text)
    with pytest.raises(ModelError, match=re.escape(str(bad))) as info:
        load_robot(bad)
    assert "joint7" in str(info.value)


def test_joint_ranges_and_ctrlranges_follow_datasheet(robot: mujoco.MjModel) -> None:
    for i, (lo, hi) in enumerate(RANGES_DEG):
        joint = robot.joint(f"joint{i + 1}")
        np.testing.assert_allclose(joint.range, np.deg2rad([lo, hi]), atol=1e-12)
        np.testing.assert_allclose(
            robot.actuator(f"actuator{i + 1}").ctrlrange, np.deg2rad([lo, hi]), atol=1e-12
        )
        assert robot.actuator(f"actuator{i + 1}").trnid[0] == joint.id


def _documented(row: str) -> float:
    """The value of a row of the calibration table in models/README.md ('| K_q,2 [N·m/rad] | 1 918 000 | ...')."""
    text = (models_dir() / "README.md").read_text(encoding="utf-8")
    match = re.search(r"^\| " + re.escape(row) + r" \| ([0-9 .]+) \|", text, flags=re.MULTILINE)
    assert match, f"row {row!r} missing from models/README.md"
    return float(match.group(1).replace(" ", ""))


def test_actuator_kp_and_friction_are_the_documented_calibration(robot: mujoco.MjModel) -> None:
    kp = robot.actuator_gainprm[:6, 0]
    documented = [_documented(f"K_q,{i} [N·m/rad]") for i in (1, 2, 3, 5)]
    np.testing.assert_allclose(kp[[0, 1, 2, 4]], documented, rtol=1e-9)
    np.testing.assert_allclose(kp[[3, 5]], _documented("K_q,4, K_q,6 [N·m/rad]"), rtol=1e-9)
    friction = [_documented(f"friction joint {i} [N·m]") for i in (2, 3, 5)]
    np.testing.assert_allclose(robot.dof_frictionloss[[1, 2, 4]], friction, rtol=1e-9)
    assert robot.dof_frictionloss[[0, 3, 5]].tolist() == [0.0, 0.0, 0.0]
    np.testing.assert_allclose(robot.actuator_biasprm[:6, 1], -kp)
    assert np.all(robot.actuator_forcelimited[:6] == 0), "joint springs must not saturate"
    np.testing.assert_allclose(robot.dof_damping, 0.01 * kp, rtol=2e-3)


def test_total_mass_is_about_1000_kg(robot: mujoco.MjModel) -> None:
    assert 990.0 < robot.body_subtreemass[0] < 1010.0
    assert robot.body("ft_sensor").mass[0] == pytest.approx(2.7)
    assert robot.body("tool").mass[0] == pytest.approx(2.0)


def test_tool_chain_geometry(robot: mujoco.MjModel) -> None:
    data = mujoco.MjData(robot)
    mujoco.mj_resetDataKeyframe(robot, data, robot.key("home").id)
    mujoco.mj_kinematics(robot, data)
    flange = data.site("attachment_site")
    R_flange = flange.xmat.reshape(3, 3)
    offset = R_flange.T @ (data.site("tcp").xpos - flange.xpos)
    np.testing.assert_allclose(offset, [0.0, 0.0, TOOL_LENGTH_M], atol=1e-12)
    np.testing.assert_allclose(data.site("tcp").xmat, flange.xmat, atol=1e-12)
    assert robot.site("ft_site").bodyid[0] == robot.body("tool").id
    assert robot.body("tool").parentid[0] == robot.body("ft_sensor").id
    assert robot.body("ft_sensor").parentid[0] == robot.body("link6").id
    tip = robot.geom("tool_tip_visual")
    assert tip.size[0] == pytest.approx(0.0075)
    assert tip.pos[2] + tip.size[0] == pytest.approx(robot.site("tcp").pos[2], abs=1e-12)
    for name in ("ft_force", "ft_torque"):
        sensor = robot.sensor(name)
        assert sensor.objid[0] == robot.site("ft_site").id


def test_sheet_origin_is_tcp_at_home_with_base_axes(scene: mujoco.MjModel) -> None:
    data = mujoco.MjData(scene)
    mujoco.mj_resetDataKeyframe(scene, data, scene.key("home").id)
    mujoco.mj_kinematics(scene, data)
    np.testing.assert_allclose(data.site("sheet_origin").xpos, data.site("tcp").xpos, atol=1e-9)
    np.testing.assert_allclose(data.site("sheet_origin").xmat.reshape(3, 3), np.eye(3), atol=1e-15)
    sheet = scene.geom("sheet")
    np.testing.assert_allclose(2 * sheet.size, [0.270, 0.270, 0.001])
    assert sheet.pos[2] + sheet.size[2] == pytest.approx(0.0, abs=1e-15), "origin on the top surface"


def test_cell_never_collides_and_does_not_intersect_robot_at_home(scene: mujoco.MjModel) -> None:
    sheet_body = scene.body("sheet").id
    cell = [g for g in range(scene.ngeom) if scene.geom_bodyid[g] == sheet_body]
    assert len(cell) >= 5
    assert all(scene.geom_contype[g] == 0 and scene.geom_conaffinity[g] == 0 for g in cell)
    data = mujoco.MjData(scene)
    mujoco.mj_resetDataKeyframe(scene, data, scene.key("home").id)
    mujoco.mj_forward(scene, data)
    robot_geoms = [g for g in range(scene.ngeom) if scene.geom_group[g] == 3]
    fromto = np.zeros(6)
    for g in cell:
        if scene.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            continue  # the ring's convex hull is a disk; checked against the bore below
        for r in robot_geoms:
            # the tool tip touches the sheet; tilted 0.45 deg at home its sphere dips 7.5 mm*(1-cos) = 0.2 um
            assert mujoco.mj_geomDistance(scene, data, r, g, 1.0, fromto) > -1e-6
    # tool holder / sensor stay outside the ring height, shank inside the 70 mm bore
    assert data.geom("tool_holder_collision").xpos[2] - data.site("sheet_origin").xpos[2] > 0.15
    assert scene.geom("tool_shank_collision").size[0] < 0.070


def _load_generator():
    path = models_dir() / "generate_assets.py"
    spec = importlib.util.spec_from_file_location("generate_assets", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_generate_assets_reproduces_committed_meshes(tmp_path: Path) -> None:
    written = _load_generator().write_all(tmp_path)
    assert len(written) == 8
    for path in written:
        committed = models_dir() / path.relative_to(tmp_path)
        assert committed.is_file(), f"{committed} missing: run models/generate_assets.py"
        new, old = trimesh.load_mesh(path), trimesh.load_mesh(committed)
        assert len(old.faces) <= 400, "keep meshes small"
        np.testing.assert_allclose(new.triangles, old.triangles, atol=1e-7)
