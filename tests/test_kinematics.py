"""MuJoCo kinematics: FK against the thesis DH table, Jacobian checks, IK with the tool vertical."""

from __future__ import annotations

import time

import mujoco
import numpy as np
import pytest

from twin.analysis.identify.default_stiffness import thesis_stiffness_fit
from twin.errors import InputError, ModelError, SingularityError, UnreachableError
from twin.robot.description import load_robot
from twin.robot.dh import det_jacobian_thesis, dh_fk
from twin.robot.kinematics import Kinematics, _rotation_log
from twin.robot.model import load_model

N_RANDOM = 1000
HOME_Q_RAD = load_robot().q_home
DET_J_MIN = load_robot().det_j_min_m3


@pytest.fixture(scope="module")
def kin() -> Kinematics:
    return Kinematics()


@pytest.fixture(scope="module")
def q_random(kin: Kinematics) -> np.ndarray:
    rng = np.random.default_rng(20240607)
    return rng.uniform(kin.q_min, kin.q_max, size=(N_RANDOM, 6))


def test_home_tool_points_down_at_thesis_position(kin: Kinematics) -> None:
    p, R = kin.fk(HOME_Q_RAD)
    angle_deg = np.degrees(np.arccos(-R[2, 2]))
    assert angle_deg < 0.5
    np.testing.assert_allclose(p, [1.467, -0.004, 0.424], atol=2e-3)


def test_fk_matches_dh_table_at_random_configurations(kin: Kinematics, q_random: np.ndarray) -> None:
    p_dh, R_dh = dh_fk(q_random)
    fk = [kin.fk(q) for q in q_random]
    p_mj = np.array([p for p, _ in fk])
    R_mj = np.array([R for _, R in fk])
    assert np.max(np.abs(p_mj - p_dh)) < 1e-9
    assert np.max(np.abs(R_mj - R_dh)) < 1e-9


def test_jacobian_determinant_is_thesis_eq_3_16(kin: Kinematics, q_random: np.ndarray) -> None:
    det_mj = np.array([np.linalg.det(kin.jacobian(q)) for q in q_random])
    assert np.max(np.abs(det_mj - det_jacobian_thesis(q_random))) < 1e-9


def test_jacobian_matches_finite_differences(kin: Kinematics, q_random: np.ndarray) -> None:
    h = 1e-6
    worst = 0.0
    for q in q_random[:200]:
        J = kin.jacobian(q)
        J_fd = np.empty((6, 6))
        for i in range(6):
            dq = np.zeros(6)
            dq[i] = h
            p_plus, R_plus = kin.fk(q + dq)
            p_minus, R_minus = kin.fk(q - dq)
            J_fd[:3, i] = (p_plus - p_minus) / (2 * h)
            J_fd[3:, i] = _rotation_log(R_plus @ R_minus.T) / (2 * h)
        worst = max(worst, float(np.max(np.abs(J - J_fd))))
    assert worst < 1e-6


def test_rotation_log_near_pi_and_zero() -> None:
    for angle in (0.0, 1e-9, 1.0, np.pi - 1e-4, np.pi):
        axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
        R = np.empty((3, 3))
        mujoco.mju_quat2Mat(R.ravel(), np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis]))
        w = _rotation_log(R)
        assert np.linalg.norm(w) == pytest.approx(angle, abs=1e-9)
        if 0 < angle < np.pi:
            np.testing.assert_allclose(w, angle * axis, atol=1e-8)


def test_ik_round_trips_forming_box_with_tool_vertical(kin: Kinematics) -> None:
    o = kin.p_base_sheet_origin
    grid = np.stack(
        np.meshgrid(
            np.linspace(-0.05, 0.05, 11), np.linspace(-0.015, 0.015, 7), np.linspace(-0.015, 0.005, 5)
        ),
        axis=-1,
    ).reshape(-1, 3)
    worst_p = worst_R = 0.0
    for d in grid:
        q = kin.ik(o + d)
        p, R = kin.fk(q)
        worst_p = max(worst_p, float(np.max(np.abs(p - (o + d)))))
        worst_R = max(worst_R, float(np.max(np.abs(R - kin.R_tool_down))))
        assert abs(np.linalg.det(kin.jacobian(q))) > DET_J_MIN
    assert worst_p < 1e-9  # 1e-6 mm
    assert worst_R < 1e-9


def test_r_tool_down_is_vertical_with_home_yaw(kin: Kinematics) -> None:
    R = kin.R_tool_down
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_array_equal(R[:, 2], [0.0, 0.0, -1.0])
    _, R_home = kin.fk(HOME_Q_RAD)
    x_home = R_home[:2, 0] / np.linalg.norm(R_home[:2, 0])
    np.testing.assert_allclose(R[:2, 0], x_home, atol=1e-15)


def test_ik_path_is_fast_and_continuous(kin: Kinematics) -> None:
    o = kin.p_base_sheet_origin
    n = 1000
    P = o + np.column_stack([np.linspace(-0.035, 0.035, n), np.zeros(n), np.linspace(0.0, -0.01, n)])
    t0 = time.perf_counter()
    Q = kin.ik_path(P)
    elapsed = time.perf_counter() - t0
    assert Q.shape == (n, 6)
    assert elapsed < 2.0, f"ik_path took {elapsed:.2f} s for {n} points"
    assert np.max(np.abs(np.diff(Q, axis=0))) < 1e-3
    p_end, _ = kin.fk(Q[-1])
    np.testing.assert_allclose(p_end, P[-1], atol=1e-9)


def test_ik_path_seeded_by_a_nearby_path_solves_the_same_points(kin: Kinematics) -> None:
    o = kin.p_base_sheet_origin
    n = 200
    P = o + np.column_stack([np.linspace(-0.03, 0.03, n), np.zeros(n), np.linspace(0.0, -0.01, n)])
    moved = P + np.array([0.4e-3, -0.2e-3, -1.5e-3])  # a compensation moves the command by about a millimetre
    Q = kin.ik_path(moved, q_near=kin.ik_path(P))
    np.testing.assert_allclose(Q, kin.ik_path(moved), atol=1e-9)
    with pytest.raises(InputError, match=r"q_near has shape \(3, 6\), expected \(200, 6\)"):
        kin.ik_path(moved, q_near=np.zeros((3, 6)))


def test_ik_raises_unreachable_for_far_target(kin: Kinematics) -> None:
    with pytest.raises(UnreachableError, match="did not converge"):
        kin.ik(kin.p_base_sheet_origin + np.array([5.0, 0.0, 0.0]))


def test_ik_raises_unreachable_outside_joint_range() -> None:
    spec = mujoco.MjSpec.from_file(str(load_robot().mjcf))
    spec.joint("joint1").range = [0.0, np.pi]  # home's q1 = -0.08 deg is now outside
    kin = Kinematics(spec.compile())
    with pytest.raises(UnreachableError, match="joint1"):
        kin.ik(kin.p_base_sheet_origin)


def test_ik_raises_singularity_for_wrist_singular_target(kin: Kinematics) -> None:
    # forearm almost vertical above a vertical tool: q5 = 1 deg, q2 + q3 + q5 = 180 deg
    q_s = np.deg2rad([0.0, 60.0, 119.0, 0.0, 1.0, 0.0])
    p, _ = kin.fk(q_s)
    with pytest.raises(SingularityError, match="det J"):
        kin.ik(p)


def test_ik_singularity_threshold_is_a_parameter() -> None:
    strict = Kinematics(load_model(scene=False), det_j_min=10.0)
    with pytest.raises(SingularityError, match="< 10 m"):
        strict.ik(strict.p_base_sheet_origin)


@pytest.mark.parametrize("q", [np.zeros(5), np.array([0, 0, np.nan, 0, 0, 0.0])], ids=["len5", "nan"])
def test_bad_joint_vectors_raise_input_error(kin: Kinematics, q: np.ndarray) -> None:
    with pytest.raises(InputError, match="6"):
        kin.fk(q)
    with pytest.raises(InputError):
        kin.jacobian(q)


def test_bad_targets_raise_input_error(kin: Kinematics) -> None:
    with pytest.raises(InputError, match=r"3 finite"):
        kin.ik(np.array([1.0, np.nan, 0.4]))
    with pytest.raises(InputError, match=r"\(n, 3\)"):
        kin.ik_path(np.zeros((4, 2)))
    with pytest.raises(InputError, match="> 0"):
        kin.compliance(HOME_Q_RAD, K_q=np.array([1e6, 1e6, 0.0, 1e6, 1e6, 1e6]))


def test_missing_or_broken_model_file_raises_model_error(tmp_path) -> None:
    with pytest.raises(ModelError, match="not found"):
        load_model(path=tmp_path / "nope.xml")
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(ModelError, match="does not compile"):
        load_model(path=broken)


def test_model_without_tcp_raises_model_error() -> None:
    spec = mujoco.MjSpec.from_file(str(load_robot().mjcf))
    spec.delete(spec.site("tcp"))
    with pytest.raises(ModelError, match="tcp"):
        Kinematics(spec.compile())
    with pytest.raises(ModelError, match="joint1"):
        Kinematics(mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>"))


def test_robot_only_model_uses_tcp_at_home_as_sheet_origin(kin: Kinematics) -> None:
    robot = Kinematics(load_model(scene=False))
    np.testing.assert_allclose(robot.p_base_sheet_origin, kin.p_base_sheet_origin, atol=1e-12)
    np.testing.assert_allclose(robot.joint_stiffness, kin.joint_stiffness)


def test_home_compliance_is_symmetric_positive_and_the_old_diagonal_fit_still_derives(kin: Kinematics) -> None:
    C = kin.compliance(HOME_Q_RAD)
    np.testing.assert_allclose(C, C.T, atol=1e-18)
    assert np.all(np.linalg.eigvalsh(C) > 0)
    # the pre-calibration default (diagonal K_q fitted to sym(inv(K_R(1))), y free) is still derivable:
    # it matches that target's diagonal [mm/kN] within 1 %, and reads x 2x stiffer than the calibrated model
    fit = thesis_stiffness_fit(kin)
    np.testing.assert_allclose(np.diag(fit.C_model) * 1e6, np.diag(fit.C_target) * 1e6, rtol=1e-2)
    assert fit.fitted == (0, 1, 2, 4)
    assert fit.residual_rel < 0.4
    assert C[0, 0] > 1.5 * fit.C_model[0, 0]
