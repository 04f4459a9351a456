"""Kinematics of a robot's MuJoCo model: forward kinematics, tool-tip Jacobian, inverse kinematics with the
tool held vertical, and the Cartesian compliance of the compliant joints.

Frames: world == robot base frame. The tool tip is the robot's tool site (`RobotDescription.tool_site`); the
sheet frame's default origin is the scene's sheet site (the tool tip at `home`), axes parallel to the base.
"""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
from scipy.linalg.lapack import dgesv

from twin.errors import InputError, ModelError, SingularityError, UnreachableError
from twin.robot.chain_fk import ChainFK
from twin.robot.description import load_robot
from twin.robot.facts import RobotDescription
from twin.robot.ik_batch import BatchSolution, breaks_branch, solve_points, warm_first_step
from twin.robot.model import load_model

__all__ = ["Kinematics"]


#: Stride of the coarse solve that seeds a long path's batched IK (`Kinematics._coarse_seeds`) [samples].
IK_COARSE_STRIDE = 32


def _rotation_log(R: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle) of a rotation matrix [rad]."""
    r = R.tolist()  # scalar maths on Python floats: ~5x faster than numpy for a 3x3
    w0, w1, w2 = 0.5 * (r[2][1] - r[1][2]), 0.5 * (r[0][2] - r[2][0]), 0.5 * (r[1][0] - r[0][1])
    s = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    c = 0.5 * (r[0][0] + r[1][1] + r[2][2] - 1.0)
    angle = math.atan2(s, c)
    w = np.array([w0, w1, w2])
    if c < -0.99:  # near pi the skew part loses precision: use the symmetric part
        B = 0.5 * (R + R.T) - c * np.eye(3)
        axis = B[:, int(np.argmax(np.diag(B)))]
        axis = axis / np.linalg.norm(axis) * (-1.0 if axis @ w < 0 else 1.0)
        return axis * angle
    if s < 1e-12:
        return w  # angle ~ 0: w == rotation vector to second order
    return w * (angle / s)


class Kinematics:
    """Forward/inverse kinematics and compliance on a robot's MuJoCo model (scene or robot-only).

    Args:
        model: A compiled model of the robot; None loads its scene.
        det_j_min: |det J| threshold below which IK refuses a solution [m^3]; None: the robot's.
        robot: The robot (`twin.robot.description.load_robot`); None: the default robot.
    """

    def __init__(
        self,
        model: mujoco.MjModel | None = None,
        det_j_min: float | None = None,
        robot: str | Path | RobotDescription | None = None,
    ) -> None:
        self.robot = load_robot(robot)
        self.model = load_model(scene=True, robot=self.robot) if model is None else model
        self.data = mujoco.MjData(self.model)
        self.det_j_min = float(self.robot.det_j_min_m3 if det_j_min is None else det_j_min)
        m = self.model
        addresses = self.robot.addresses(m)
        try:
            self._tcp_id = m.site(self.robot.tool_site).id
        except KeyError:
            raise ModelError(f"model lacks the tool site {self.robot.tool_site!r} of robot {self.robot.name!r}") from None
        joint_ids = addresses.joint
        self.dof = self.robot.dof
        self._qadr = addresses.qpos
        self._dadr = addresses.dof
        self._actuators = addresses.actuator
        self.q_min = m.jnt_range[joint_ids, 0].copy()
        self.q_max = m.jnt_range[joint_ids, 1].copy()
        self._jacp = np.zeros((3, m.nv))
        self._jacr = np.zeros((3, m.nv))
        self._damping = 1e-10 * np.eye(self.dof)
        self._chain = ChainFK(m, self._tcp_id, self._qadr)
        self._last_batch: BatchSolution | None = None  # the last path's batch IK (`_ik_batch`)
        self.q_home = self.robot.q_home
        _p_home, R_home = self.fk(self.q_home)
        # the tool's heading at home: its x axis in the horizontal (its y where x is vertical, a tool pointing along
        # the ground at home), else the base's x
        x = next((v for v in (np.array([R_home[0, i], R_home[1, i], 0.0]) for i in (0, 1))
                  if np.linalg.norm(v) > 1e-6), np.array([1.0, 0.0, 0.0]))
        x = x / np.linalg.norm(x)
        z = np.array([0.0, 0.0, -1.0])
        self.R_tool_down = np.column_stack([x, np.cross(z, x), z])
        sites = [m.site(i).name for i in range(m.nsite)]
        if self.robot.sheet_site is not None and self.robot.sheet_site in sites:
            mujoco.mj_kinematics(m, self.data)
            self.p_base_sheet_origin = self.data.site(self.robot.sheet_site).xpos.copy()
        else:
            self.p_base_sheet_origin = _p_home

    def _check_q(self, q: np.ndarray) -> np.ndarray:
        arr = np.asarray(q, dtype=float)
        if arr.shape != (self.dof,):
            raise InputError(f"q must be {self.dof} joint angles [rad], got shape {arr.shape}: {arr}")
        if not np.all(np.isfinite(arr)):
            raise InputError(f"q must be {self.dof} finite joint angles [rad], got {arr}")
        return arr

    def _set(self, q: np.ndarray) -> None:
        self.data.qpos[self._qadr] = q
        mujoco.mj_kinematics(self.model, self.data)

    @property
    def joint_stiffness(self) -> np.ndarray:
        """K_q of the compliant joints: the gains of their position actuators [N m/rad]."""
        return self.model.actuator_gainprm[self._actuators, 0].copy()

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tool-tip pose: p_base_tcp [m] (3,) and R_base_tcp (3, 3) for joint angles q (dof,) [rad]."""
        self._set(self._check_q(q))
        site = self.data.site(self._tcp_id)
        return site.xpos.copy(), site.xmat.reshape(3, 3).copy()

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Geometric Jacobian of `tcp`, rows [linear; angular] in the base frame, (6, dof) [m/rad; 1]."""
        self._set(self._check_q(q))
        return self._jac()

    def _jac(self) -> np.ndarray:
        mujoco.mj_comPos(self.model, self.data)
        mujoco.mj_jacSite(self.model, self.data, self._jacp, self._jacr, self._tcp_id)
        J = np.empty((6, self.dof))
        J[:3] = self._jacp[:, self._dadr]
        J[3:] = self._jacr[:, self._dadr]
        return J

    def compliance(self, q: np.ndarray, K_q: np.ndarray | None = None) -> np.ndarray:
        """Translational Cartesian compliance J_v K_q^-1 J_v^T at q, (3, 3) [m/N].

        Args:
            q: Joint angles (dof,) [rad].
            K_q: Joint stiffnesses (dof,) [N m/rad]; None uses `joint_stiffness`.
        """
        K = self.joint_stiffness if K_q is None else self.robot.joint_vector(K_q, "K_q", "N m/rad", positive=True)
        J_v = self.jacobian(q)[:3]
        return (J_v / K) @ J_v.T

    def ik(self, p_base_tcp: np.ndarray, q_seed: np.ndarray | None = None, max_iter: int = 60) -> np.ndarray:
        """Joint angles putting the tool tip at `p_base_tcp` with orientation `R_tool_down`.

        Damped Newton on the 6-D pose error, seeded at home (or `q_seed`) so it stays on home's branch.

        Args:
            p_base_tcp: Target tool-tip position in the base frame (3,) [m].
            q_seed: Start configuration (dof,) [rad]; None uses `q_home`.
            max_iter: Newton iterations allowed.

        Raises:
            UnreachableError: No convergence to 1e-9 m / 1e-9 rad, or the solution leaves the joint ranges.
            SingularityError: |det J| < `det_j_min` at the solution.
        """
        target = np.asarray(p_base_tcp, dtype=float)
        if target.shape != (3,) or not np.all(np.isfinite(target)):
            raise InputError(f"p_base_tcp must be 3 finite coordinates [m], got {target}")
        q = self.q_home.copy() if q_seed is None else self._check_q(q_seed).copy()
        return self._ik(target, q, max_iter)[0]

    def _ik(self, target: np.ndarray, q: np.ndarray, max_iter: int) -> tuple[np.ndarray, np.ndarray]:
        """`ik` from the start configuration `q`; returns the solution and the Jacobian there."""
        R_t = self.R_tool_down
        xpos = self.data.site_xpos[self._tcp_id]  # views: they follow every mj_kinematics
        xmat = self.data.site_xmat[self._tcp_id].reshape(3, 3)
        e = np.empty(6)
        err_p = err_r = math.inf
        for _ in range(max_iter):
            self._set(q)
            np.subtract(target, xpos, out=e[:3])
            e[3:] = _rotation_log(R_t @ xmat.T)
            ep, er = e[:3] @ e[:3], e[3:] @ e[3:]
            err_p, err_r = math.sqrt(ep), math.sqrt(er)
            if err_p < 1e-12 and err_r < 1e-12:
                break
            J = self._jac()
            _, _, dq, info = dgesv(J.T @ J + self._damping, J.T @ e)
            if info != 0:
                raise SingularityError(f"IK normal equations are singular at q={q} rad (LAPACK info {info})")
            step = float(abs(dq).max())
            q = q + (dq * (0.2 / step) if step > 0.2 else dq)
        if not (err_p < 1e-9 and err_r < 1e-9):
            raise UnreachableError(
                f"IK did not converge for p_base_tcp={target} m: position error {err_p:.3g} m, "
                f"orientation error {err_r:.3g} rad after {max_iter} iterations (need < 1e-9)"
            )
        bad = np.flatnonzero((q < self.q_min - 1e-12) | (q > self.q_max + 1e-12))
        if bad.size:
            i = int(bad[0])
            raise UnreachableError(
                f"IK solution for p_base_tcp={target} m leaves the range of {self.robot.joints[i]}: q={q[i]:.6g} rad, "
                f"valid [{self.q_min[i]:.6g}, {self.q_max[i]:.6g}] rad"
            )
        J = self._jac()
        det = float(np.linalg.det(J))
        if abs(det) < self.det_j_min:
            raise SingularityError(
                f"IK solution for p_base_tcp={target} m is near-singular: |det J| = {abs(det):.3g} m^3 "
                f"< {self.det_j_min:.3g} m^3 at q={q} rad"
            )
        return q, J

    def ik_path(
        self, P_base_tcp: np.ndarray, q_seed: np.ndarray | None = None, *, q_near: np.ndarray | None = None
    ) -> np.ndarray:
        """IK along a path, each point warm-started from the previous solution.

        Args:
            P_base_tcp: Tool-tip positions in the base frame (n, 3) [m].
            q_seed: Seed of the first point (dof,) [rad]; None uses `q_home`.
            q_near: A solution of a nearby path (n, dof) [rad] (the path before a small change, e.g. the last
                command of a compensation): it seeds every point, so a few Newton steps suffice.

        Returns:
            Q of shape (n, dof) [rad].
        """
        P = np.asarray(P_base_tcp, dtype=float)
        if P.ndim != 2 or P.shape[1] != 3:
            raise InputError(f"P_base_tcp must have shape (n, 3) [m], got {P.shape}")
        finite = np.all(np.isfinite(P), axis=1)
        if not np.all(finite):
            bad = P[int(np.argmin(finite))]
            raise InputError(f"p_base_tcp must be 3 finite coordinates [m], got {bad}")
        q0 = self.q_home.copy() if q_seed is None else self._check_q(q_seed).copy()
        near = None if q_near is None else np.asarray(q_near, dtype=float)
        if near is not None and near.shape != (P.shape[0], self.dof):
            raise InputError(f"q_near has shape {near.shape}, expected {(P.shape[0], self.dof)}")
        Q = self._ik_batch(P, q0 if near is None else near)
        return Q if Q is not None else self._ik_sequential(P, q0)

    def _ik_sequential(self, P: np.ndarray, q: np.ndarray) -> np.ndarray:
        """`ik` point by point, each warm-started from a first-order prediction off the previous solution."""
        Q = np.empty((P.shape[0], self.dof))
        twist = np.zeros(6)
        J = np.eye(6, self.dof)
        for i, p in enumerate(P):
            if i > 0:
                # q + J^-1 [dp; 0] (the orientation is fixed): one Newton step is then enough; a prediction
                # beyond the damped step limit falls back to the plain warm start
                twist[:3] = p - P[i - 1]
                _, _, dq, info = dgesv(J, twist)
                if info == 0 and float(abs(dq).max()) <= 0.2:
                    q = q + dq
            q, J = self._ik(p, q, 60)
            Q[i] = q
        return Q

    def _ik_batch(self, P: np.ndarray, q_seed: np.ndarray) -> np.ndarray | None:
        """`ik_points` from `_coarse_seeds` (seeds that are the last path's solution take their first step from
        its Jacobians, `twin.robot.ik_batch.warm_first_step`), or None (the caller then solves point by point,
        raising the precise error) when a point fails or the solution leaves the branch (`breaks_branch`)."""
        if P.shape[0] < 2:
            return None
        first = warm_first_step(self._last_batch, P, q_seed) if q_seed.ndim == 2 else None
        solved = self._ik_points(P, self._coarse_seeds(P, q_seed), first=first)
        if solved is None or not solved[1].all():
            return None
        Q, _, J = solved
        if breaks_branch(self.ik_points, P[None], Q[None])[0]:
            return None
        self._last_batch = BatchSolution(P.copy(), Q.copy(), J)
        return Q

    def _coarse_seeds(self, P: np.ndarray, q_seed: np.ndarray) -> np.ndarray:
        """Per-point seeds of a long path: the solutions at every `IK_COARSE_STRIDE`-th point (from `q_seed`),
        interpolated joint by joint, so each point starts a Newton step or two from its solution (the Ø160 mm
        cone's IK: 0.61 -> 0.2 s); `q_seed` itself for a short path, per-point seeds or a failed coarse solve."""
        n = P.shape[0]
        if q_seed.ndim != 1 or n < 4 * IK_COARSE_STRIDE:
            return q_seed
        idx = np.unique(np.r_[np.arange(0, n, IK_COARSE_STRIDE), n - 1])
        coarse = self.ik_points(P[idx], q_seed)
        if coarse is None or not coarse[1].all():
            return q_seed
        return np.column_stack([np.interp(np.arange(n), idx, coarse[0][:, j]) for j in range(self.dof)])

    def ik_points(
        self, P_base_tcp: np.ndarray, q_seed: np.ndarray, max_iter: int = 30
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The damped Newton of `ik` for independent points at once (numpy kinematics), each from its seed.

        Args: P_base_tcp (n, 3) [m] in the base frame; q_seed one seed (dof,) or one per point (n, dof) [rad].

        Returns:
            The solutions (n, dof) [rad] and whether each converged inside the joint ranges with |det J| >=
            `det_j_min` (n,); None when the chain is not supported (then use `ik_path` or `ik`).
        """
        solved = self._ik_points(np.asarray(P_base_tcp, dtype=float), q_seed, max_iter)
        return None if solved is None else (solved[0], solved[1])

    def _ik_points(
        self, P: np.ndarray, q_seed: np.ndarray, max_iter: int = 30, first: tuple[np.ndarray, np.ndarray] | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """`ik_points` (`twin.robot.ik_batch.solve_points`, its first step from `first` if given) and the
        Jacobians at the converged solutions (n, 6, dof)."""
        if not self._chain.supported:
            return None
        solved = solve_points(self._chain, self.R_tool_down, self._damping, P, q_seed, max_iter, first)
        if solved is None:
            return None
        Q, ok, J_final = solved
        ok &= ~np.any((self.q_min - 1e-12 > Q) | (self.q_max + 1e-12 < Q), axis=1)
        ok[ok] &= np.abs(np.linalg.det(J_final[ok])) >= self.det_j_min
        return Q, ok, J_final

    def jacobians(self, Q: np.ndarray) -> np.ndarray:
        """`jacobian` at many configurations, (n, 6, dof) [m/rad; 1] (vectorised when the chain allows).

        Args:
            Q: Joint angles (n, dof) [rad].
        """
        arr = np.asarray(Q, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != self.dof or not np.all(np.isfinite(arr)):
            raise InputError(f"Q must be finite joint angles of shape (n, {self.dof}) [rad], got shape {arr.shape}")
        if self._chain.supported:
            return self._chain(arr)[2]
        return np.array([self.jacobian(q) for q in arr])
