"""Denavit-Hartenberg kinematics from a robot's DH table (`RobotDescription.dh`), and the TX200's Eq. 3.16.

An independent check of the MJCF model: `dh_fk` does not use MuJoCo. For the TX200 the table is the thesis's
Table 3.3 (models/tx200.toml), and `det_jacobian_thesis` is the closed form the thesis gives for the
determinant of its geometric Jacobian.
"""

from __future__ import annotations

import numpy as np

from twin.errors import InputError, ModelError
from twin.robot.description import load_robot
from twin.robot.facts import DhTable


def _table(dh: DhTable | None) -> DhTable:
    """`dh`, or the default robot's table."""
    table = load_robot().dh if dh is None else dh
    if table is None:
        raise ModelError("the robot's description has no [dh] table")
    return table


def _as_joint_array(q: np.ndarray, dof: int) -> np.ndarray:
    """Validate joint angles: shape (dof,) or (n, dof), finite [rad]."""
    arr = np.asarray(q, dtype=float)
    if arr.ndim not in (1, 2) or arr.shape[-1] != dof:
        raise InputError(f"joint angles must have shape ({dof},) or (n, {dof}) [rad], got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"joint angles must be finite, got {arr}")
    return arr


def dh_transforms(q: np.ndarray, tool_length_m: float | None = None, dh: DhTable | None = None) -> np.ndarray:
    """Homogeneous transforms of DH frames 0..dof and of the tool tip (vectorised).

    Args:
        q: Joint angles q_i (not theta), shape (dof,) or (n, dof) [rad].
        tool_length_m: Distance flange -> tool tip along the flange z axis [m]; None: the default robot's.
        dh: The DH table; None: the default robot's.

    Returns:
        Array of shape (..., dof + 2, 4, 4): base-frame poses of frames 0..dof, then of the tool tip.
    """
    table = _table(dh)
    dof = len(table.d_m)
    tool_m = load_robot().tool_length_m if tool_length_m is None else tool_length_m
    q_arr = _as_joint_array(q, dof)
    batch = q_arr.shape[:-1]
    out = np.zeros((*batch, dof + 2, 4, 4))
    T = np.broadcast_to(np.eye(4), (*batch, 4, 4)).copy()
    out[..., 0, :, :] = T
    d_m, a_m, offset = np.array(table.d_m), np.array(table.a_m), np.array(table.offset_rad)
    ca, sa = np.cos(table.alpha_rad), np.sin(table.alpha_rad)
    for i in range(dof):
        theta = q_arr[..., i] + offset[i]
        ct, st = np.cos(theta), np.sin(theta)
        A = np.zeros((*batch, 4, 4))
        A[..., 0, 0], A[..., 0, 1], A[..., 0, 2], A[..., 0, 3] = ct, -st * ca[i], st * sa[i], a_m[i] * ct
        A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 3] = st, ct * ca[i], -ct * sa[i], a_m[i] * st
        A[..., 2, 1], A[..., 2, 2], A[..., 2, 3] = sa[i], ca[i], d_m[i]
        A[..., 3, 3] = 1.0
        T = T @ A
        out[..., i + 1, :, :] = T
    tool = np.eye(4)
    tool[2, 3] = tool_m
    out[..., dof + 1, :, :] = T @ tool
    return out


def dh_fk(
    q: np.ndarray, tool_length_m: float | None = None, dh: DhTable | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Tool-tip pose from the DH table, the tool along the FLANGE z axis (not the base z axis of Appendix B).

    Args:
        q: Joint angles, shape (dof,) or (n, dof) [rad].
        tool_length_m: Distance flange -> tool tip along the flange z axis [m]; None: the default robot's.
        dh: The DH table; None: the default robot's.

    Returns:
        p_base_tcp of shape (..., 3) [m] and R_base_tcp of shape (..., 3, 3).
    """
    T = dh_transforms(q, tool_length_m, dh)[..., -1, :, :]
    return T[..., :3, 3].copy(), T[..., :3, :3].copy()


def dh_jacobian(q: np.ndarray, tool_length_m: float | None = None, dh: DhTable | None = None) -> np.ndarray:
    """Geometric Jacobian of the tool tip from the DH table, rows [linear; angular] in the base frame.

    Args:
        q: Joint angles, shape (dof,) or (n, dof) [rad].
        tool_length_m: Distance flange -> tool tip along the flange z axis [m]; None: the default robot's.
        dh: The DH table; None: the default robot's.

    Returns:
        Array (..., 6, dof): column i is [z_{i-1} x (p_tcp - o_{i-1}); z_{i-1}] [m/rad; 1].
    """
    T = dh_transforms(q, tool_length_m, dh)
    dof = T.shape[-3] - 2
    z = T[..., :dof, :3, 2]
    o = T[..., :dof, :3, 3]
    p = T[..., -1:, :3, 3]
    lin = np.cross(z, p - o)
    return np.concatenate([np.swapaxes(lin, -1, -2), np.swapaxes(z, -1, -2)], axis=-2)


def det_jacobian_thesis(q: np.ndarray) -> float | np.ndarray:
    """Determinant of the TX200's geometric Jacobian, thesis Eq. 3.16 [m^3].

    det J = -19/2500 sin q5 [80 cos q2 + 26 sin q3 + 95 sin q2 sin q3 - 80 cos q2 cos^2 q3
            + 80 cos q3 sin q2 sin q3]

    It holds with the joint angles q_i (the MuJoCo qpos), not with theta_i = q_i + offset_i, and for any
    tool length (moving the reference point does not change the determinant).

    Args:
        q: Joint angles, shape (6,) or (n, 6) [rad].

    Returns:
        det J as a float for one configuration, else an array of shape (n,) [m^3].
    """
    q_arr = _as_joint_array(q, 6)  # Eq. 3.16 is the TX200's own
    q2, q3, q5 = q_arr[..., 1], q_arr[..., 2], q_arr[..., 4]
    bracket = (
        80 * np.cos(q2)
        + 26 * np.sin(q3)
        + 95 * np.sin(q2) * np.sin(q3)
        - 80 * np.cos(q2) * np.cos(q3) ** 2
        + 80 * np.cos(q3) * np.sin(q2) * np.sin(q3)
    )
    det = -19 / 2500 * np.sin(q5) * bracket
    return float(det) if q_arr.ndim == 1 else det
