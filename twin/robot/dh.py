"""Denavit-Hartenberg kinematics of the TX200 exactly as printed in the thesis (Table 3.3, Eq. 3.16).

An independent check of the MJCF model: `dh_fk` does not use MuJoCo, and `det_jacobian_thesis` is the
closed form the thesis gives for the determinant of the geometric Jacobian.
"""

from __future__ import annotations

import numpy as np

from twin.errors import InputError

# Table 3.3: A_i = Rot_z(theta_i) Trans_z(d_i) Trans_x(a_i) Rot_x(alpha_i), theta_i = q_i + offset_i.
DH_D_M = np.array([0.64, 0.0, 0.0, 0.8, 0.0, 0.19])
DH_A_M = np.array([0.26, 0.95, 0.0, 0.0, 0.0, 0.0])
DH_ALPHA_RAD = np.array([-np.pi / 2, 0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0.0])
THETA_OFFSET_RAD = np.array([0.0, -np.pi / 2, -np.pi / 2, 0.0, 0.0, np.pi / 2])

# Tool length flange -> tip of the hemispherical punch, sphere fit on 4 poses (thesis §3.2.1) [m].
TOOL_LENGTH_M = 0.27494


def _as_joint_array(q: np.ndarray) -> np.ndarray:
    """Validate joint angles: shape (6,) or (n, 6), finite [rad]."""
    arr = np.asarray(q, dtype=float)
    if arr.ndim not in (1, 2) or arr.shape[-1] != 6:
        raise InputError(f"joint angles must have shape (6,) or (n, 6) [rad], got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"joint angles must be finite, got {arr}")
    return arr


def dh_transforms(q: np.ndarray, tool_length_m: float = TOOL_LENGTH_M) -> np.ndarray:
    """Homogeneous transforms of DH frames 0..6 and of the tool tip (vectorised).

    Args:
        q: Joint angles q_1..q_6 of the thesis (not theta), shape (6,) or (n, 6) [rad].
        tool_length_m: Distance flange -> tool tip along the flange z axis [m].

    Returns:
        Array of shape (..., 8, 4, 4): base-frame poses of frames 0..6, then of the tool tip.
    """
    q_arr = _as_joint_array(q)
    batch = q_arr.shape[:-1]
    out = np.zeros((*batch, 8, 4, 4))
    T = np.broadcast_to(np.eye(4), (*batch, 4, 4)).copy()
    out[..., 0, :, :] = T
    ca, sa = np.cos(DH_ALPHA_RAD), np.sin(DH_ALPHA_RAD)
    for i in range(6):
        theta = q_arr[..., i] + THETA_OFFSET_RAD[i]
        ct, st = np.cos(theta), np.sin(theta)
        A = np.zeros((*batch, 4, 4))
        A[..., 0, 0], A[..., 0, 1], A[..., 0, 2], A[..., 0, 3] = ct, -st * ca[i], st * sa[i], DH_A_M[i] * ct
        A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 3] = st, ct * ca[i], -ct * sa[i], DH_A_M[i] * st
        A[..., 2, 1], A[..., 2, 2], A[..., 2, 3] = sa[i], ca[i], DH_D_M[i]
        A[..., 3, 3] = 1.0
        T = T @ A
        out[..., i + 1, :, :] = T
    tool = np.eye(4)
    tool[2, 3] = tool_length_m
    out[..., 7, :, :] = T @ tool
    return out


def dh_fk(q: np.ndarray, tool_length_m: float = TOOL_LENGTH_M) -> tuple[np.ndarray, np.ndarray]:
    """Tool-tip pose from Table 3.3, the tool along the FLANGE z axis (not the base z axis of Appendix B).

    Args:
        q: Joint angles q_1..q_6, shape (6,) or (n, 6) [rad].
        tool_length_m: Distance flange -> tool tip along the flange z axis [m].

    Returns:
        p_base_tcp of shape (..., 3) [m] and R_base_tcp of shape (..., 3, 3).
    """
    T = dh_transforms(q, tool_length_m)[..., 7, :, :]
    return T[..., :3, 3].copy(), T[..., :3, :3].copy()


def dh_jacobian(q: np.ndarray, tool_length_m: float = TOOL_LENGTH_M) -> np.ndarray:
    """Geometric Jacobian of the tool tip from Table 3.3, rows [linear; angular] in the base frame.

    Args:
        q: Joint angles, shape (6,) or (n, 6) [rad].
        tool_length_m: Distance flange -> tool tip along the flange z axis [m].

    Returns:
        Array (..., 6, 6): column i is [z_{i-1} x (p_tcp - o_{i-1}); z_{i-1}] [m/rad; 1].
    """
    T = dh_transforms(q, tool_length_m)
    z = T[..., :6, :3, 2]
    o = T[..., :6, :3, 3]
    p = T[..., 7:8, :3, 3]
    lin = np.cross(z, p - o)
    return np.concatenate([np.swapaxes(lin, -1, -2), np.swapaxes(z, -1, -2)], axis=-2)


def det_jacobian_thesis(q: np.ndarray) -> float | np.ndarray:
    """Determinant of the geometric Jacobian, thesis Eq. 3.16 [m^3].

    det J = -19/2500 sin q5 [80 cos q2 + 26 sin q3 + 95 sin q2 sin q3 - 80 cos q2 cos^2 q3
            + 80 cos q3 sin q2 sin q3]

    It holds with the joint angles q_i (the MuJoCo qpos), not with theta_i = q_i + offset_i, and for any
    tool length (moving the reference point does not change the determinant).

    Args:
        q: Joint angles, shape (6,) or (n, 6) [rad].

    Returns:
        det J as a float for one configuration, else an array of shape (n,) [m^3].
    """
    q_arr = _as_joint_array(q)
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
