"""The KUKA KR 210 R2700 robot folder (models/kr210): description, kinematics, KRL axis values, forming and plants.

The URDF joint origins below are the public descriptions the DH table was derived from (models/kr210/README.md):
each check compares them, the DH table and the MuJoCo model with one another.
"""

from __future__ import annotations

import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.plant import build_plant
from twin.lab.dynamic.simulate import simulate
from twin.process.description import Process
from twin.process.toolpath.placement import check_reach
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.robot.description import load_robot, shipped_robots
from twin.robot.dh import dh_fk
from twin.robot.kinematics import Kinematics
from twin.robot.model import load_model
from twin.sim.spec import TwinSpec

ROBOT = "kr210"
# ros-industrial/kuka_experimental PR 158 (commit 01ae9a4c) kr210r2700extra_macro.xacro: (origin xyz, axis) per
# joint, all origin rpy zero; tool0 ($FLANGE) = link_6 turned by rpy (0, pi/2, 0)
ROS_I_JOINTS = [((0, 0, 0.675), (0, 0, -1)), ((0.35, 0, 0), (0, 1, 0)), ((1.15, 0, 0), (0, 1, 0)),
                ((0, 0, -0.041), (-1, 0, 0)), ((1.2, 0, 0), (0, 1, 0)), ((0.215, 0, 0), (-1, 0, 0))]
# kroshu/kuka_robot_descriptions (commit d913c020) kr210_r2700_extra_macro.xacro: (origin xyz, origin rpy), axes z;
# tool0 = link_6 turned by rpy (pi, 0, pi)
KUKA_ROS2_JOINTS = [((0, 0, 0.302), (np.pi, 0, 0)), ((0.35, 0, -0.373), (np.pi / 2, 0, 0)), ((1.15, 0, 0), (0, 0, 0)),
                    ((0.9, 0.041, 0), (np.pi / 2, 0, -np.pi / 2)), ((0, 0, -0.3), (0, np.pi / 2, np.pi / 2)),
                    ((0.215, 0, 0), (np.pi / 2, 0, -np.pi / 2))]


def _frame(xyz: tuple[float, ...], rotation: Rotation) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rotation.as_matrix(), xyz
    return T


def _ros_i_flange(axis_deg: np.ndarray) -> np.ndarray:
    """Pose of `tool0` in the ROS-I description for KUKA axis values (its joint values) [deg]."""
    T = np.eye(4)
    for (xyz, axis), a in zip(ROS_I_JOINTS, np.deg2rad(axis_deg), strict=True):
        T = T @ _frame(xyz, Rotation.identity()) @ _frame((0, 0, 0), Rotation.from_rotvec(np.array(axis) * a))
    return T @ _frame((0, 0, 0), Rotation.from_euler("xyz", (0, np.pi / 2, 0)))


def _kuka_ros2_flange(axis_deg: np.ndarray) -> np.ndarray:
    """Pose of `tool0` in KUKA's ROS 2 description for KUKA axis values [deg]."""
    T = np.eye(4)
    for (xyz, rpy), a in zip(KUKA_ROS2_JOINTS, np.deg2rad(axis_deg), strict=True):
        T = T @ _frame(xyz, Rotation.from_euler("xyz", rpy)) @ _frame((0, 0, 0), Rotation.from_euler("z", a))
    return T @ _frame((0, 0, 0), Rotation.from_euler("xyz", (np.pi, 0, np.pi)))


@pytest.fixture(scope="module")
def kin() -> Kinematics:
    return Kinematics(robot=ROBOT)


@pytest.fixture(scope="module")
def cone():
    return part_path(PartSpec(shape="cone", top_half_width_m=0.03, depth_m=0.01))


def test_the_folder_is_a_shipped_robot_described_from_public_numbers() -> None:
    assert shipped_robots()[ROBOT].parts[-2:] == ("kr210", "robot.toml")
    robot = load_robot(ROBOT)
    assert (robot.vendor, robot.controller, robot.language) == ("KUKA", "KR C4", "KRL")
    assert robot.tool_in_flange_m == (0.0, 0.0, 0.27494)  # the TX200 cell's sensor and tool
    assert robot.calibrated_stiffness == () and robot.calibrated_friction == ()
    assert robot.datasheet is not None and robot.datasheet.payload_kg == 210.0
    # the model's K_q are the stated priors, every prior with a source
    model = load_model(scene=False, robot=robot)
    kp = model.actuator_gainprm[robot.addresses(model).actuator, 0]
    priors = {p.joint: p for p in robot.stiffness_priors}
    np.testing.assert_array_equal(kp, [priors[j].k_nm_per_rad for j in robot.joints])
    assert all(p.source.startswith("class estimate:") for p in priors.values())
    # the masses of KUKA's ROS 2 description (1068.08 kg) plus the sensor and the tool
    assert model.body_subtreemass[model.body("base").id] == pytest.approx(1068.08 + 2.7 + 2.0)


def test_dh_table_is_the_public_urdf_and_the_controller_angles_are_krl_axis_values() -> None:
    robot = load_robot(ROBOT)
    rng = np.random.default_rng(7)
    for q in rng.uniform(robot.q_min_rad, robot.q_max_rad, (100, robot.dof)):
        axis_deg = np.rad2deg(robot.controller_angles(q))
        p, R = dh_fk(q, tool_length_m=0.0, dh=robot.dh)  # the flange
        for T in (_ros_i_flange(axis_deg), _kuka_ros2_flange(axis_deg)):
            np.testing.assert_allclose(T[:3, 3], p, atol=1e-12)
            np.testing.assert_allclose(T[:3, :3], R, atol=1e-12)
    # KUKA's HOME {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}: upper arm vertical, forearm horizontal, flange forward
    q_home_krl = np.deg2rad([0.0, -90.0, 90.0, 0.0, 0.0, 0.0]) * np.array(robot.controller_sign)
    p, R = dh_fk(q_home_krl, tool_length_m=0.0, dh=robot.dh)
    np.testing.assert_allclose(p, [0.35 + 1.2 + 0.215, 0.0, 0.675 + 1.15 - 0.041], atol=1e-12)
    np.testing.assert_allclose(R[:, 2], [1.0, 0.0, 0.0], atol=1e-12)
    # A1 > 0 turns the arm clockwise seen from above
    p_a1, _ = dh_fk(np.array([-0.1, -1.0, 1.5, 0.0, 0.5, 0.0]), tool_length_m=0.0, dh=robot.dh)
    assert robot.controller_angles(np.array([-0.1, 0, 0, 0, 0, 0]))[0] > 0 and p_a1[1] < 0


def test_home_is_a_clean_forming_pose(kin: Kinematics) -> None:
    robot = kin.robot
    q = robot.q_home
    p, R = kin.fk(q)
    np.testing.assert_allclose(R[:, 2], [0.0, 0.0, -1.0], atol=1e-12)  # tool straight down
    assert 1.5 <= p[0] <= 1.9 and abs(p[1]) < 1e-9 and 0.3 <= p[2] <= 0.7
    np.testing.assert_allclose(kin.p_base_sheet_origin, p, atol=1e-12)  # the scene's sheet origin
    assert abs(np.degrees(q[4])) > 25.0
    margin = np.degrees(np.minimum(q - kin.q_min, kin.q_max - q))
    assert margin.min() >= 20.0
    assert abs(np.linalg.det(kin.jacobian(q))) > 10 * robot.det_j_min_m3
    scene = load_model(scene=True, robot=robot)
    data = mujoco.MjData(scene)
    mujoco.mj_resetDataKeyframe(scene, data, scene.key(robot.home_keyframe).id)
    mujoco.mj_forward(scene, data)
    assert data.ncon == 0
    rng = np.random.default_rng(1234)
    for _ in range(500):
        data.ctrl[:] = q + rng.normal(0.0, 0.01, robot.dof)
        mujoco.mj_step(scene, data)
    assert sum(int(w.number) for w in data.warning) == 0
    assert np.max(np.abs(data.qpos - q)) < 0.05


def test_ik_round_trip_over_the_forming_box_and_the_cone_is_reachable(kin: Kinematics, cone) -> None:
    o = kin.p_base_sheet_origin
    for dx in (-0.05, 0.0, 0.05):
        for dy in (-0.05, 0.0, 0.05):
            for dz in (-0.015, 0.005):
                target = o + np.array([dx, dy, dz])
                q = kin.ik(target)
                p, R = kin.fk(q)
                np.testing.assert_allclose(p, target, atol=1e-9)
                np.testing.assert_allclose(R, kin.R_tool_down, atol=1e-9)
                assert abs(np.linalg.det(kin.jacobian(q))) > kin.robot.det_j_min_m3
    report = check_reach(cone, kinematics=kin)
    assert report.min_abs_det_j > 10 * kin.robot.det_j_min_m3
    assert np.degrees(report.joint_margin_rad).min() > 20.0


def test_compliance_at_home(kin: Kinematics) -> None:
    C = kin.compliance(kin.q_home) * 1e6  # mm/kN
    np.testing.assert_allclose(C, C.T, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(C) > 0)
    assert np.all((np.diag(C) > 0.5) & (np.diag(C) < 10.0)), C
    readme = (Path(__file__).resolve().parents[1] / "models" / "kr210" / "README.md").read_text(encoding="utf-8")
    block = readme.split("Home compliance J K_q⁻¹ Jᵀ [mm/kN]")[1].split("```")[1]
    np.testing.assert_allclose(C, np.array([[float(v) for v in re.findall(r"-?\d+\.\d+", line)]
                                            for line in block.strip().splitlines()]), atol=2e-3)


def test_the_twin_forms_the_cone_with_the_isf_force_model(cone) -> None:
    twin = TwinSpec(robot=load_robot(ROBOT), process=Process(force_model="isf")).build()
    sim = twin.simulate(cone.t_s, cone.p_sheet_m)
    deflection = np.linalg.norm(sim.p_sheet_m - cone.p_sheet_m, axis=1)
    rms_mm = 1e3 * float(np.sqrt(np.mean(deflection**2)))
    assert 0.1 < rms_mm < 2.0, rms_mm
    assert 200.0 < np.abs(sim.f_sheet_n[:, 2]).max() < 2000.0


def test_the_dynamic_plant_builds_from_the_folder_and_runs(cone) -> None:
    knobs = Knobs(neutral=True)
    plant = build_plant(knobs, robot=ROBOT)
    assert plant.robot.name == ROBOT
    prior = np.array([p.k_nm_per_rad for p in plant.robot.stiffness_priors])
    assert np.sum(np.abs(plant.k_q / prior - 1.0) >= 0.1) >= 3  # the plant's own robot, not the prior
    n = len(cone.t_s) // 16
    log = simulate(cone.t_s[:n], cone.p_sheet_m[:n], knobs, plant=plant)
    assert np.all(np.isfinite(log.p_tip_sheet_m))
    p_cmd = np.column_stack([np.interp(log.t_s, cone.t_s[:n], cone.p_sheet_m[:n, i]) for i in range(3)])
    assert 1e3 * np.max(np.linalg.norm(log.p_tip_sheet_m - p_cmd, axis=1)) < 5.0
