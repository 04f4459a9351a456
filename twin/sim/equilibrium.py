"""The quasi-static equilibrium of the compliant robot at one sample, with joint friction.

Per sample the robot is solved to quasi-static equilibrium (qvel = qacc = 0):

    r(q) = K (q_ref - q) + τ_fr - g(q) + J_tcp(q)^T f(p_tcp(q)) = 0,

with K the joint springs (position-actuator `kp`, plus the stiff link-side hinges of lost-motion joints),
g the gravity torques from `mj_rne`, J_tcp the translational site Jacobian (`mj_jacSite`) and f the force the
sheet exerts on the tool, from the stateful field. Newton's method with the matrix
K + dg/dq - J^T (df/dp) J (gravity gradient by finite differences once per run) converges in 2-3
iterations to 1e-10 rad. This direct solve was chosen over damped stepping (hundreds of `mj_step` per
sample) because it is exact at equilibrium and an order of magnitude cheaper per sample.

Joint friction (the model's `frictionloss`, Coulomb, against the link's motion) enters as a torque τ_fr:
a joint the command turns slides, and its spring carries -τ_f·sign(q̇) (an offset that flips when the
joint reverses); a joint at rest sticks until its torque changes by more than τ_f (`EquilibriumSolver.solve`).

The twin (`twin.sim.quasi_static.Twin`) calls `EquilibriumSolver.solve` once per sample.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np
from scipy.linalg.lapack import dgesv as _dgesv

NEWTON_TOL_RAD = 1e-7  # a Newton step this small leaves < 1e-9 m of error (quadratic convergence)
NEWTON_MAX_ITER = 20
# A joint slower than this is at rest for its friction [rad/s]: the groove's joints 2, 3, 5 turn at ~0.02
# rad/s while forming, joint 1 at ~6e-5 rad/s (the tool stays at y ~ 0), deflections change slower still.
JOINT_REST_RAD_PER_S = 1e-3
FRICTION_MAX_ROUNDS = 6  # active-set rounds of the stick/slip solve; 1-2 suffice in practice


def joint_motion(t_s: np.ndarray, q: np.ndarray, rest_rad_per_s: float = JOINT_REST_RAD_PER_S) -> np.ndarray:
    """Sign of each joint's commanded velocity per sample (0 where slower than `rest_rad_per_s`).

    Args:
        t_s: Sample times [s], shape (n,).
        q: Joint path [rad], shape (n, 6).
        rest_rad_per_s: Speed below which a joint counts as at rest [rad/s].

    Returns:
        -1, 0 or +1 per sample and joint, shape (n, 6).
    """
    qdot = np.gradient(q, t_s, axis=0) if len(t_s) >= 2 else np.zeros_like(q)
    return np.where(np.abs(qdot) > rest_rad_per_s, np.sign(qdot), 0.0)


class EquilibriumSolver:
    """Newton's method on the equilibrium of one model's joints, with an active set for joint friction.

    Args:
        model: The twin's compiled model (position actuators as springs, `frictionloss`, site `tcp`); shared
            with the twin, so changes of its springs or friction apply.
        data: Its data; qpos and the kinematics are overwritten.
        tcp_site: Id of the `tcp` site.
        p_base_sheet_origin: Sheet origin in the base frame [m], shape (3,).
    """

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, tcp_site: int, p_base_sheet_origin: np.ndarray
    ) -> None:
        self.model, self.data = model, data
        self._tcp = tcp_site
        self.p_base_sheet_origin = p_base_sheet_origin

    def _newton(
        self,
        q: np.ndarray,
        q_ref: np.ndarray,
        k_diag: np.ndarray,
        h_const: np.ndarray,
        sheet: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
        stick: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, int, np.ndarray, np.ndarray, np.ndarray]:
        """Newton's method on K (q_ref - q) + τ_fr - g(q) + J_tcp(q)^T f(p(q)) = 0 from `q`.

        Args:
            q: Start [rad], shape (nq,).
            q_ref: Spring references (set-points taught under gravity) [rad], shape (nq,).
            k_diag: Joint springs [N·m/rad], shape (nv,).
            h_const: K + dg/dq, the Newton matrix without the sheet term, shape (nv, nv).
            sheet: Tool-tip position in the sheet frame [m] -> (force on the tool [N], df/dp [N/m]).
            stick: None (no friction), or (stuck, e_stuck, tau_fr): dofs whose elastic deflection q_ref - q is
                held at e_stuck [rad] (the joint sticks), and the friction torque of the slipping ones [N·m].

        Returns:
            The equilibrium [rad], the iterations used, the translational tcp Jacobian [m/rad] and df/dp
            [N/m] of the last iteration, and the demanded joint torque g - J^T f there [N·m].
        """
        m, d = self.model, self.data
        jacp = np.zeros((3, m.nv))
        g = np.zeros(m.nv)
        stiffness = np.zeros((3, 3))
        force = np.zeros(3)
        xpos_tcp = d.site_xpos[self._tcp]  # a view: follows every mj_kinematics
        k = 0
        for k in range(1, NEWTON_MAX_ITER + 1):  # noqa: B007
            d.qpos[:] = q
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_rne(m, d, 0, g)
            mujoco.mj_jacSite(m, d, jacp, None, self._tcp)
            force, stiffness = sheet(xpos_tcp - self.p_base_sheet_origin)
            r = k_diag * (q_ref - q) - g + jacp.T @ force
            h = h_const - jacp.T @ stiffness @ jacp
            if stick is not None:
                stuck, e_stuck, tau_fr = stick
                r += tau_fr
                r[stuck] = (k_diag * (q_ref - e_stuck - q))[stuck]
                h[stuck, :] = 0.0
                h[stuck, stuck] = k_diag[stuck]
            _, _, dq, info = _dgesv(h, r)  # np.linalg.solve costs 5x more
            if info != 0:
                raise np.linalg.LinAlgError(f"singular Newton matrix (LAPACK dgesv info {info}) at q = {q!r}")
            q = q + dq
            if abs(dq).max() < NEWTON_TOL_RAD:
                break
        return q, k, jacp, stiffness, g - jacp.T @ force

    def solve(
        self,
        q: np.ndarray,
        q_ref: np.ndarray,
        k_diag: np.ndarray,
        h_const: np.ndarray,
        sheet: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
        e_prev: np.ndarray,
        motion: np.ndarray | None = None,
    ) -> tuple[np.ndarray, int, np.ndarray, np.ndarray]:
        """Equilibrium with joint friction: sliding for moving joints, stick/slip for joints at rest.

        Coulomb friction τ_f in a joint acts on the link against its motion. A joint the command moves
        (`motion` = ±1) slides: the friction torque is -τ_f·motion, and its gear spring carries it, so the
        elastic deflection shifts by τ_f/K and flips when the joint reverses. A joint at rest (`motion` = 0)
        holds its elastic deflection e = q_ref - q while the torque the friction must add, |D - K e_prev| with
        D = g - J^T f, stays within τ_f (stick); beyond, it slips and carries K e = D - τ_f·sign(D - K e_prev).
        Starting with every resting frictional joint stuck, joints whose needed friction exceeds τ_f slip,
        and slipping joints that would move against their friction stick again, until the set is consistent
        (a few rounds at most).

        Args:
            q, q_ref, k_diag, h_const, sheet: As for `_newton`.
            e_prev: Elastic deflection after the previous sample [rad], shape (nv,).
            motion: Sign of each dof's commanded velocity (0 at rest), shape (nv,); None: all at rest.

        Returns:
            As `_newton`, without the demanded torque; iterations summed over the rounds.
        """
        tau_f = self.model.dof_frictionloss
        if not tau_f.any():
            q, k, jac, s, _ = self._newton(q, q_ref, k_diag, h_const, sheet)
            return q, k, jac, s
        sliding = np.zeros(len(tau_f), dtype=bool) if motion is None else motion != 0.0
        frictional = (tau_f > 0.0) & ~sliding
        stuck = frictional.copy()
        tau_fr = np.zeros_like(tau_f) if motion is None else -tau_f * motion
        total = 0
        for _ in range(FRICTION_MAX_ROUNDS):
            q, k, jac, s, demand = self._newton(q, q_ref, k_diag, h_const, sheet, (stuck, e_prev, tau_fr))
            total += k
            need = demand - k_diag * e_prev
            slip = stuck & (np.abs(need) > tau_f)
            moved = q_ref - q - e_prev
            back = frictional & ~stuck & (moved * tau_fr < 0.0)
            if not (slip.any() or back.any()):
                break
            stuck = (stuck & ~slip) | back
            tau_fr = np.where(slip, tau_f * np.sign(need), np.where(back, 0.0, tau_fr))
        return q, total, jac, s
