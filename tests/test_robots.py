"""Every shipped robot passes the checks the TX200 passes (kinematics against its own DH table, IK over a forming
box, the cone in reach, the twin and the dynamic plant build from its folder), the `robots` listing gives the
source of every number, and runs keep the robot they were made with."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import page_differences

from twin.analysis.replay import replay
from twin.cli import main
from twin.errors import InputError
from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.plant import build_plant
from twin.process.description import Process
from twin.process.toolpath.placement import check_reach
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.robot.description import load_robot, shipped_robots
from twin.robot.dh import dh_fk, dh_jacobian
from twin.robot.kinematics import Kinematics
from twin.runs.read import read_run
from twin.sim.spec import TwinSpec

ROBOTS = sorted(shipped_robots())
CONE = PartSpec(shape="cone", top_half_width_m=0.03, depth_m=0.01)


@pytest.mark.parametrize("name", ROBOTS)
def test_mujoco_kinematics_equal_the_dh_table_at_random_poses(name: str) -> None:
    robot = load_robot(name)
    assert robot.dh is not None and robot.dh.source, f"{name}: the independent kinematics need a [dh] with a source"
    kin = Kinematics(robot=robot)
    q = np.random.default_rng(3).uniform(kin.q_min, kin.q_max, size=(200, robot.dof))
    p_dh, R_dh = dh_fk(q, tool_length_m=robot.tool_length_m, dh=robot.dh)
    fk = [kin.fk(qi) for qi in q]
    assert np.max(np.abs(np.array([p for p, _ in fk]) - p_dh)) < 1e-9
    assert np.max(np.abs(np.array([R for _, R in fk]) - R_dh)) < 1e-9
    np.testing.assert_allclose(kin.jacobians(q[:20]), dh_jacobian(q[:20], robot.tool_length_m, robot.dh), atol=1e-9)


@pytest.mark.parametrize("name", ROBOTS)
def test_each_robot_forms_the_cone_at_its_default_placement(name: str) -> None:
    """Reach with margin and a well-conditioned Jacobian over the Ø 60 mm cone, then the twin's deflection."""
    robot = load_robot(name)
    kin = Kinematics(robot=robot)
    path = part_path(CONE)
    reach = check_reach(path, kinematics=kin)
    assert reach.min_abs_det_j > 2 * robot.det_j_min_m3
    assert np.min(reach.joint_margin_rad) > np.radians(10.0)
    _, R = kin.fk(kin.q_home)
    assert np.degrees(np.arccos(min(1.0, -R[2, 2]))) < 0.5  # home: the tool points down
    twin = TwinSpec(robot=robot, process=Process(force_model="isf")).build()
    sim = twin.simulate(path.t_s, path.p_sheet_m)
    miss = np.sqrt(np.mean(np.sum((sim.p_sheet_m - path.p_sheet_m) ** 2, axis=1)))
    assert 0.05e-3 < miss < 5e-3, f"{name}: rms deflection {1e3 * miss:.3f} mm"


@pytest.mark.parametrize("name", ROBOTS)
def test_the_dynamic_plant_builds_from_each_robot_folder(name: str) -> None:
    plant = build_plant(Knobs(neutral=True), name)
    assert plant.robot.name == name and plant.k_q.shape == (plant.robot.dof,)


def test_the_listing_gives_every_number_a_source(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "--json", "-"]) == 0
    robots = {r["name"]: r for r in json.loads(capsys.readouterr().out)["robots"]}
    assert set(robots) == set(ROBOTS) and len(ROBOTS) >= 3
    for name, r in robots.items():
        assert r["reach_mm"] > 0 and r["payload_kg"] > 0 and r["datasheet_source"], name
        assert r["kinematics_source"], name
        assert len(r["stiffness_priors"]) == 6 and all(p["source"] for p in r["stiffness_priors"]), name
        assert np.all(np.linalg.eigvalsh(np.array(r["compliance_task_point_mm_per_kn"])) > 0), name
    languages = {r["language"] for r in robots.values()}
    assert {"VAL3", "KRL", "RAPID"} <= languages


def test_a_run_keeps_its_robot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A run made with one robot replays on that robot; a twin or a --robot of another one is refused."""
    other = next(name for name in ROBOTS if name != "tx200")
    cone = tmp_path / "cone.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "40", "--depth-mm", "2", "--robot", other,
                 "--out", str(cone)]) == 0
    assert main(["lab", "--scenario", "nominal", "--commanded", str(cone), "--robot", other, "--seed", "1",
                 "--out", str(tmp_path / "run")]) == 0
    run = read_run(tmp_path / "run")
    assert run.meta["robot"] == other
    capsys.readouterr()
    assert main(["replay", str(tmp_path / "run"), "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["position_rms_mm"] < 0.05  # the run's robot, by itself
    assert main(["replay", str(tmp_path / "run"), "--robot", "tx200"]) == 2
    assert "was made with" in capsys.readouterr().err
    with pytest.raises(InputError, match="robot"):
        replay(run, TwinSpec(robot=load_robot("tx200")))


def test_an_unknown_robot_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", "--robot", "kr9000"]) == 2
    err = capsys.readouterr().err
    assert "unknown robot 'kr9000'" in err and "tx200" in err
    broken = tmp_path / "robot.toml"
    shutil.copy(load_robot().source, broken)
    broken.write_text(broken.read_text().replace('mjcf = "tx200.xml"', 'mjcf = "missing.xml"'))
    assert main(["info", "--robot", str(broken)]) == 2
    assert "missing.xml" in capsys.readouterr().err


def _user_copy(folder: Path, edit) -> Path:
    """The TX200's robot-only MJCF, edited, with its meshes beside it."""
    shutil.copytree(load_robot().mjcf.parent / "assets", folder / "assets", dirs_exist_ok=True)
    target = folder / "mine.xml"
    target.write_text(edit(load_robot().mjcf.read_text()))
    return target


def test_a_users_mjcf_without_an_ft_frame_or_a_joint_limit_is_a_clear_error(tmp_path: Path) -> None:
    from twin.errors import ModelError

    no_ft = _user_copy(tmp_path, lambda s: s.replace('<site name="ft_site"/>', "").replace(
        'name="ft_sensor"', 'name="sensor_body"'))
    with pytest.raises(ModelError, match="no F/T sensor frame"):
        load_robot(no_ft)
    no_tool = _user_copy(tmp_path, lambda s: s.replace('<site name="tcp"', '<site name="tip"'))
    with pytest.raises(ModelError, match="no tool frame"):
        load_robot(no_tool)
    free = _user_copy(tmp_path, lambda s: s.replace(' range="-3.141592653589793 3.141592653589793"', "", 1))
    with pytest.raises(ModelError, match=r"joint\(s\) \['joint1'\] have no limits"):
        load_robot(free)


def test_a_users_mjcf_without_springs_or_home_loads_with_the_assumptions_stated(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import re

    bare = _user_copy(tmp_path, lambda s: re.sub(r"<keyframe>.*?</keyframe>", "",
                                                  re.sub(r"<actuator>.*?</actuator>", "", s, flags=re.S), flags=re.S))
    assert main(["info", "--robot", str(bare), "--json", "-"]) == 0
    captured = capsys.readouterr()
    assert "no position actuator" in captured.err and "no 'home' keyframe" in captured.err
    info = json.loads(captured.out)
    assert info["joint_stiffness_nm_per_rad"] == [1e6] * 6


def test_a_users_urdf_with_tool_and_ft_links_loads(tmp_path: Path) -> None:
    """Six revolute joints, links `ft_sensor` and `tcp` on fixed joints: read by MuJoCo, completed, kinematics."""
    links = "".join(f'<link name="l{i}"><inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" '
                    f'ixz="0" iyz="0"/></inertial></link>' for i in range(7))
    axes = ["0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 1 0", "1 0 0"]
    origins = ["0 0 0.5", "0.2 0 0.3", "0 0 0.9", "0.8 0 0.1", "0.1 0 0", "0.1 0 0"]
    joints = "".join(
        f'<joint name="j{i + 1}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/><origin xyz="{o}"/>'
        f'<axis xyz="{a}"/><limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>'
        for i, (a, o) in enumerate(zip(axes, origins, strict=True)))
    tail = ('<link name="ft_sensor"/><link name="tcp"/>'
            '<joint name="f1" type="fixed"><parent link="l6"/><child link="ft_sensor"/><origin xyz="0.05 0 0"/></joint>'
            '<joint name="f2" type="fixed"><parent link="ft_sensor"/><child link="tcp"/><origin xyz="0.25 0 0"/></joint>')
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(f'<robot name="arm">{links}{joints}{tail}</robot>')
    with pytest.warns(UserWarning, match="a URDF has none"):
        robot = load_robot(urdf)
    assert robot.dof == 6 and robot.tool_length_m == pytest.approx(0.3)
    kin = Kinematics(robot=robot)
    p, _ = kin.fk(np.zeros(6))
    np.testing.assert_allclose(p, [0.2 + 0.8 + 0.1 + 0.1 + 0.3, 0.0, 0.5 + 0.3 + 0.9 + 0.1], atol=1e-12)


def test_the_robots_page_is_the_one_a_fresh_run_writes(tmp_path: Path) -> None:
    page = Path(__file__).resolve().parent.parent / "docs" / "robots.md"
    assert main(["robots", "--markdown", str(tmp_path / "robots.md")]) == 0
    assert page_differences(page.read_text(), (tmp_path / "robots.md").read_text()) == [], (
        "docs/robots.md is stale: run `tx200-twin robots --markdown docs/robots.md`")
