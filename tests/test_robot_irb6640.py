"""The ABB IRB 6640-185/2.8 robot folder (models/irb6640): it loads, its MJCF is its DH table and the ROS-I URDF,
the twin and the dynamic plant run on it, and its home pose is a forming pose."""

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
from twin.robot.kinematics import Kinematics
from twin.robot.model import load_model
from twin.sim.spec import TwinSpec

NAME = "irb6640"
# ABB IRB 6640 axis ranges [deg] (the ROS-I URDF's limits, from ABB's data sheet 3HAC 028284-001)
RANGES_DEG = [(-170, 170), (-65, 85), (-180, 70), (-300, 300), (-120, 120), (-360, 360)]
# ROS-Industrial abb_irb6640_support urdf/irb6640_185_280_macro.xacro: joint origins [m] and axes, tool0 rpy
URDF_ORIGINS = [(0, 0, 0.780), (0.320, 0, 0), (0, 0, 1.075), (0, 0, 0.2), (1.392, 0, 0), (0.2, 0, 0)]
URDF_AXES = [(0, 0, 1), (0, 1, 0), (0, 1, 0), (1, 0, 0), (0, 1, 0), (1, 0, 0)]
TOOL0_RPY = (0.0, np.pi / 2, 0.0)
README = Path(__file__).resolve().parents[1] / "models" / "irb6640" / "README.md"
PRIORS = [3.76e6, 3.21e6, 2.09e6, 8.39e5, 4.07e5, 8.39e5]  # robot.toml's class estimate of K_q [N m/rad]


@pytest.fixture(scope="module")
def robot():
    return load_robot(NAME)


@pytest.fixture(scope="module")
def kin(robot) -> Kinematics:
    return Kinematics(robot=robot)


@pytest.fixture(scope="module")
def cone():
    return part_path(PartSpec(shape="cone", top_half_width_m=0.03, depth_m=0.01))


def _urdf_tool0(q: np.ndarray) -> np.ndarray:
    """tool0 pose of the ROS-I URDF at joint angles q (its own chain, not the DH table)."""
    T = np.eye(4)
    for origin, axis, angle in zip(URDF_ORIGINS, URDF_AXES, q, strict=True):
        step = np.eye(4)
        step[:3, 3] = origin
        step[:3, :3] = Rotation.from_rotvec(np.array(axis, dtype=float) * angle).as_matrix()
        T = T @ step
    tool0 = np.eye(4)
    tool0[:3, :3] = Rotation.from_euler("xyz", TOOL0_RPY).as_matrix()
    return T @ tool0


def test_the_folder_is_a_shipped_robot_with_its_facts(robot) -> None:
    assert shipped_robots()[NAME] == robot.source
    assert robot.source.parent.name == NAME and robot.mjcf.name == "irb6640.xml" and robot.scene.name == "scene.xml"
    assert (robot.vendor, robot.controller, robot.language) == ("ABB", "IRC5", "RAPID")
    assert robot.joints == tuple(f"joint{i}" for i in range(1, 7))
    assert robot.lost_motion_joints == ("joint2", "joint3")
    assert robot.tool_in_flange_m == (0.0, 0.0, 0.27494)
    assert robot.calibrated_stiffness == () and robot.calibrated_friction == ()
    assert robot.datasheet.reach_m == pytest.approx(2.8) and robot.datasheet.payload_kg == pytest.approx(185.0)
    np.testing.assert_allclose(np.degrees(robot.datasheet.joint_speed_rad_s), [100, 90, 90, 170, 140, 190])
    # the IRC5's axis values are the MJCF's q (robot.toml explains why)
    np.testing.assert_array_equal(robot.controller_angles(robot.q_home), robot.q_home)
    assert [p.k_nm_per_rad for p in robot.stiffness_priors] == PRIORS
    assert all(p.source.startswith("class estimate:") for p in robot.stiffness_priors)


def test_mjcf_joints_springs_and_masses(robot) -> None:
    model = load_model(scene=False, robot=robot)
    arm = robot.addresses(model)
    np.testing.assert_allclose(np.degrees(model.jnt_range[arm.joint]), RANGES_DEG, atol=1e-12)
    np.testing.assert_allclose(model.actuator_ctrlrange[arm.actuator], model.jnt_range[arm.joint])
    kp = model.actuator_gainprm[arm.actuator, 0]
    np.testing.assert_array_equal(kp, PRIORS)
    np.testing.assert_allclose(model.dof_damping[arm.dof], 0.01 * kp, rtol=0.02)
    assert np.all(model.dof_frictionloss[arm.dof][[1, 2, 4]] > 0)
    assert np.all(model.dof_frictionloss[arm.dof][[0, 3, 5]] == 0)
    assert model.body_subtreemass[0] == pytest.approx(1310.0 + 2.7 + 2.0)
    assert model.nmesh == 0


def test_mujoco_fk_is_the_urdf_chain(robot, kin) -> None:
    """MuJoCo against the ROS-I URDF's own chain (the DH table: tests/test_robots.py, every robot)."""
    rng = np.random.default_rng(6640)
    lo, hi = np.array(robot.q_min_rad), np.array(robot.q_max_rad)
    for q in rng.uniform(lo, hi, (200, 6)):
        p, R = kin.fk(q)
        flange = _urdf_tool0(q)
        np.testing.assert_allclose(p, flange[:3, 3] + robot.tool_length_m * flange[:3, 2], atol=1e-9)
        np.testing.assert_allclose(R, flange[:3, :3], atol=1e-9)


def test_home_is_a_forming_pose(robot, kin) -> None:
    q = robot.q_home
    p, R = kin.fk(q)
    np.testing.assert_allclose(R[:, 2], [0.0, 0.0, -1.0], atol=1e-12)  # tool straight down
    assert 1.5 <= p[0] <= 2.0 and abs(p[1]) < 1e-9 and 0.3 <= p[2] <= 0.7
    assert abs(np.degrees(q[4])) > 25.0
    margin = np.degrees(np.minimum(q - robot.q_min_rad, robot.q_max_rad - q))
    assert margin.min() >= 20.0
    assert abs(np.linalg.det(kin.jacobian(q))) > 10 * robot.det_j_min_m3
    scene = load_model(scene=True, robot=robot)
    data = mujoco.MjData(scene)
    mujoco.mj_resetDataKeyframe(scene, data, scene.key(robot.home_keyframe).id)
    mujoco.mj_forward(scene, data)
    assert data.ncon == 0 and sum(int(w.number) for w in data.warning) == 0
    np.testing.assert_array_equal(scene.key(robot.home_keyframe).ctrl, scene.key(robot.home_keyframe).qpos)
    np.testing.assert_allclose(data.site(robot.sheet_site).xpos, data.site(robot.tool_site).xpos, atol=1e-9)
    np.testing.assert_allclose(data.site(robot.sheet_site).xmat.reshape(3, 3), np.eye(3), atol=1e-15)
    sheet = scene.body("sheet").id
    cell = [g for g in range(scene.ngeom) if scene.geom_bodyid[g] == sheet]
    assert all(scene.geom_contype[g] == 0 and scene.geom_conaffinity[g] == 0 for g in cell)
    np.testing.assert_allclose(2 * scene.geom("sheet").size, [0.270, 0.270, 0.001])


def test_ik_round_trip_over_the_forming_box(kin, robot) -> None:
    p_home, _ = kin.fk(kin.q_home)
    for dx in (-0.05, 0.0, 0.05):
        for dy in (-0.05, 0.0, 0.05):
            for dz in (-0.015, 0.005):
                target = p_home + np.array([dx, dy, dz])
                q = kin.ik(target)
                p, R = kin.fk(q)
                np.testing.assert_allclose(p, target, atol=1e-9)
                np.testing.assert_allclose(R, kin.R_tool_down, atol=1e-9)
                assert abs(np.linalg.det(kin.jacobian(q))) > 10 * robot.det_j_min_m3


def test_cone_is_in_reach_and_the_twin_forms_it(robot, kin, cone) -> None:
    report = check_reach(cone, kinematics=kin)
    assert report.min_abs_det_j > 10 * robot.det_j_min_m3
    assert np.degrees(report.joint_margin_rad).min() > 20.0
    twin = TwinSpec(robot=robot, process=Process(force_model="isf")).build()
    sim = twin.simulate(cone.t_s, cone.p_sheet_m)
    rms = float(np.sqrt(np.mean(np.sum(sim.deflection_sheet_m**2, axis=1))))
    # about 1.1 mm with the class estimate of K_q (the TX200's calibrated model: about 1.0 mm on the same cone)
    assert 0.6e-3 < rms < 2.0e-3
    said = re.search(r"rms deflection ([\d.]+) mm \(x ([\d.]+), y ([\d.]+), z ([\d.]+) mm rms; largest ([\d.]+) mm",
                     README.read_text(encoding="utf-8"))
    assert said is not None  # models/irb6640/README.md's numbers are this run's
    d = 1e3 * sim.deflection_sheet_m
    measured = [1e3 * rms, *np.sqrt(np.mean(d**2, axis=0)), float(np.linalg.norm(d, axis=1).max())]
    np.testing.assert_allclose([float(v) for v in said.groups()], measured, atol=0.01)
    assert np.all(np.isfinite(sim.p_sheet_m))


def test_home_compliance(kin) -> None:
    C = kin.compliance(kin.q_home) * 1e6  # mm/kN
    np.testing.assert_allclose(C, C.T, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(C) > 0)
    np.testing.assert_allclose(np.diag(C), [1.417, 0.902, 1.195], atol=2e-3)
    block = README.read_text(encoding="utf-8").split("J K_q⁻¹ Jᵀ [mm/kN]")[1].split("```")[1]
    np.testing.assert_allclose(C, np.array([[float(v) for v in re.findall(r"-?\d+\.\d+|0\.(?!\d)", line)]
                                            for line in block.strip().splitlines()]), atol=2e-3)


def test_dynamic_plant_builds_and_runs(robot, cone) -> None:
    plant = build_plant(Knobs(neutral=True), robot=NAME)
    assert plant.robot.name == NAME
    assert np.sum(np.abs(plant.k_q / np.asarray(PRIORS) - 1.0) >= 0.1) >= 3  # the plant's own robot, not the prior
    np.testing.assert_allclose(plant.p_base_sheet_origin, Kinematics(robot=robot).fk(robot.q_home)[0], atol=1e-9)
    n = int(np.searchsorted(cone.t_s, 1.0))
    log = simulate(cone.t_s[:n], cone.p_sheet_m[:n], Knobs(neutral=True), process=Process(force_model="isf"),
                   plant=plant)
    assert np.all(np.isfinite(log.p_tip_sheet_m))
    commanded = np.column_stack([np.interp(log.t_s, cone.t_s[:n], cone.p_sheet_m[:n, k]) for k in range(3)])
    assert np.max(np.linalg.norm(log.p_tip_sheet_m - commanded, axis=1)) < 1e-3  # tracking, not yet loaded
