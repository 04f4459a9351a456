"""The thesis DH table (Table 3.3) and its Jacobian determinant (Eq. 3.16), without MuJoCo."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import InputError
from twin.robot.description import load_robot
from twin.robot.dh import det_jacobian_thesis, dh_fk, dh_jacobian

HOME_Q_RAD = np.deg2rad([-0.08, 38.03, 90.62, -0.33, 51.72, -7.91])  # thesis Table 4.1
THETA_OFFSET_RAD = np.array(load_robot().dh.offset_rad)
TOOL_LENGTH_M = load_robot().tool_length_m


@pytest.fixture(scope="module")
def q_random() -> np.ndarray:
    rng = np.random.default_rng(7)
    return rng.uniform(-np.pi, np.pi, size=(1000, 6))


def test_home_pose_puts_tool_down_at_thesis_position() -> None:
    p, R = dh_fk(HOME_Q_RAD)
    np.testing.assert_allclose(p, [1.467, -0.004, 0.424], atol=2e-3)
    assert np.degrees(np.arccos(-R[2, 2])) < 0.5


def test_zero_pose_is_the_upright_candle() -> None:
    p, R = dh_fk(np.zeros(6), tool_length_m=0.0)
    # q = 0 (Staubli zero): upper arm, forearm and flange all vertical above the shoulder offset a1
    np.testing.assert_allclose(p, [0.26, 0.0, 0.64 + 0.95 + 0.8 + 0.19], atol=1e-12)
    np.testing.assert_allclose(R[:, 2], [0.0, 0.0, 1.0], atol=1e-12)


def test_tool_is_added_along_flange_z(q_random: np.ndarray) -> None:
    p0, R0 = dh_fk(q_random, tool_length_m=0.0)
    p1, _ = dh_fk(q_random)
    np.testing.assert_allclose(p1 - p0, TOOL_LENGTH_M * R0[:, :, 2], atol=1e-12)


def test_eq_3_16_is_det_of_dh_jacobian_in_joint_angles_q(q_random: np.ndarray) -> None:
    det = np.linalg.det(dh_jacobian(q_random))
    assert np.max(np.abs(det - det_jacobian_thesis(q_random))) < 1e-12
    # the formula is in q_i, not in theta_i = q_i + offset_i
    det_theta = det_jacobian_thesis(q_random + THETA_OFFSET_RAD)
    assert np.max(np.abs(det - det_theta)) > 0.1


def test_det_is_independent_of_tool_length(q_random: np.ndarray) -> None:
    det_flange = np.linalg.det(dh_jacobian(q_random, tool_length_m=0.0))
    det_tool = np.linalg.det(dh_jacobian(q_random))
    np.testing.assert_allclose(det_flange, det_tool, atol=1e-12)


def test_det_at_home_and_scalar_return() -> None:
    det = det_jacobian_thesis(HOME_Q_RAD)
    assert isinstance(det, float)
    assert det == pytest.approx(-0.87697, abs=1e-5)


@pytest.mark.parametrize("q", [np.zeros(5), np.full(6, np.inf), np.zeros((2, 7))], ids=["len5", "inf", "2x7"])
def test_bad_joint_arrays_raise_input_error(q: np.ndarray) -> None:
    with pytest.raises(InputError, match="joint angles"):
        dh_fk(q)
    with pytest.raises(InputError, match="joint angles"):
        det_jacobian_thesis(q)
