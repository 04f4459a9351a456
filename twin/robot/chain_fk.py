"""Vectorised forward kinematics of the tool tip for the arm's hinge chain (many configurations at once).

Used by `twin.robot.kinematics` for batched IK and Jacobians along a path.
"""

from __future__ import annotations

import mujoco
import numpy as np


def quat_mat(quat: np.ndarray) -> np.ndarray:
    """Rotation matrix of a MuJoCo (w, x, y, z) quaternion."""
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(quat, dtype=float))
    return R.reshape(3, 3)


class ChainFK:
    """Vectorised forward kinematics of the site `tcp` for a chain of hinge joints (numpy, many q at once).

    Same composition as `mj_kinematics` (body offset, then each hinge about its anchor), with rotation
    matrices instead of quaternions: agrees with MuJoCo to rounding (~1e-16 m). `supported` is False when
    the chain to the site holds a joint other than the arm's hinges (`qadr`); callers then use MuJoCo per sample.
    """

    def __init__(self, model: mujoco.MjModel, site_id: int, qadr: np.ndarray) -> None:
        m = model
        chain = []
        body = int(m.site_bodyid[site_id])
        while body != 0:
            chain.append(body)
            body = int(m.body_parentid[body])
        self.steps: list[tuple[np.ndarray, np.ndarray, list[tuple[int, np.ndarray, np.ndarray, float]]]] = []
        arm = {int(a): i for i, a in enumerate(qadr)}
        self.supported = True
        for b in reversed(chain):
            joints = []
            for j in range(int(m.body_jntadr[b]), int(m.body_jntadr[b]) + int(m.body_jntnum[b])):
                adr = int(m.jnt_qposadr[j])
                if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE or adr not in arm:
                    self.supported = False
                axis = m.jnt_axis[j] / np.linalg.norm(m.jnt_axis[j])
                joints.append((arm.get(adr, -1), axis.copy(), m.jnt_pos[j].copy(), float(m.qpos0[adr])))
            self.steps.append((m.body_pos[b].copy(), quat_mat(m.body_quat[b]), joints))
        self.dof = len(qadr)
        self.site_pos = m.site_pos[site_id].copy()
        self.site_R = quat_mat(m.site_quat[site_id])

    def __call__(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Site position (n, 3) [m], site orientation (n, 3, 3) and Jacobian (n, 6, dof) [m/rad; 1] at Q (n, dof)."""
        n = Q.shape[0]

        def rot(R: np.ndarray, C: np.ndarray) -> np.ndarray:  # R[i] @ C for every i, one BLAS call
            return (R.reshape(-1, 3) @ C).reshape(R.shape[0], 3, C.shape[1] if C.ndim == 2 else 1)

        pos = np.zeros((n, 3))
        R = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
        axes, anchors, cols = [], [], []
        for body_pos, body_R, joints in self.steps:
            pos = pos + rot(R, body_pos[:, None])[:, :, 0]
            R = rot(R, body_R)
            for col, axis, jpos, q0 in joints:
                anchor = pos + rot(R, jpos[:, None])[:, :, 0]
                axes.append(rot(R, axis[:, None])[:, :, 0])
                anchors.append(anchor)
                cols.append(col)
                theta = Q[:, col] - q0
                K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
                # R Rot(axis, theta) = R + sin(theta) R K + (1 - cos(theta)) R K^2 (Rodrigues)
                R = (
                    R
                    + np.sin(theta)[:, None, None] * rot(R, K)
                    + (1.0 - np.cos(theta))[:, None, None] * rot(R, K @ K)
                )
                pos = anchor - rot(R, jpos[:, None])[:, :, 0]
        p_site = pos + rot(R, self.site_pos[:, None])[:, :, 0]
        J = np.zeros((n, 6, self.dof))
        for col, axis_w, anchor in zip(cols, axes, anchors, strict=True):
            J[:, :3, col] += np.cross(axis_w, p_site - anchor)
            J[:, 3:, col] += axis_w
        return p_site, rot(R, self.site_R), J


def rotation_log_batch(M: np.ndarray) -> np.ndarray | None:
    """`_rotation_log` of many rotations (n, 3, 3); None if one is near pi (use the scalar one there)."""
    w = 0.5 * np.stack([M[:, 2, 1] - M[:, 1, 2], M[:, 0, 2] - M[:, 2, 0], M[:, 1, 0] - M[:, 0, 1]], axis=1)
    s = np.sqrt(np.sum(w * w, axis=1))
    c = 0.5 * (M[:, 0, 0] + M[:, 1, 1] + M[:, 2, 2] - 1.0)
    if np.any(c < -0.99):
        return None
    angle = np.arctan2(s, c)
    factor = np.where(s < 1e-12, 1.0, angle / np.where(s < 1e-12, 1.0, s))
    return w * factor[:, None]
