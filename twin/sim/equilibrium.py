"""The quasi-static equilibrium of the compliant robot at one sample, with joint friction.

Per sample the robot is solved to quasi-static equilibrium (qvel = qacc = 0):

    r(q) = K (q_ref - q) + τ_fr - g(q) + J_tcp(q)^T f(p_tcp(q)) = 0,

with K the joint springs (position-actuator `kp`, plus the stiff link-side hinges of lost-motion joints),
g the gravity torques from `mj_rne`, J_tcp the translational site Jacobian (`mj_jacSite`) and f the force the
sheet exerts on the tool, from the stateful field. Newton's method with the matrix
K + dg/dq - J^T (df/dp) J (gravity gradient by finite differences once per run) converges in 2-3
iterations to 1e-10 rad. This direct solve was chosen over damped stepping (hundreds of `mj_step` per
sample) because it is exact at equilibrium and an order of magnitude cheaper per sample.

Joint friction (the model's `frictionloss`, Coulomb, against the link's motion) enters as a torque τ_fr
(`EquilibriumSolver.solve`): each sample, a joint's link stays where it was (stick) while the torque its
friction must supply stays within τ_f, and slides otherwise. A joint the command keeps turning slides every
sample, its spring carrying the extra τ_f; when the command reverses, the link holds until the motor has wound
its spring through 2·τ_f/K_q, a dead band made by the friction itself.

The twin's Python loop (`twin.sim.python_loop`) calls `EquilibriumSolver.solve` once per sample; its compiled
loop (`twin.sim.compiled.loop`) runs the same algorithm, decision for decision.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import mujoco
import numpy as np
from scipy.linalg.lapack import dgesv as _dgesv

NEWTON_TOL_RAD = 1e-7  # a Newton step this small leaves < 1e-9 m of error (quadratic convergence)
NEWTON_MAX_ITER = 40
# Past this many iterations Newton is cycling (the sheet's force law has a kink where the tool lifts off the
# surface it meets, and near the end walls the equilibrium sits on it): the steps are halved from then on.
NEWTON_DAMPED_AFTER = 10
FRICTION_MAX_ROUNDS = 6  # active-set rounds of the stick/slip solve; 1-2 suffice in practice


class Equilibrium(NamedTuple):
    """One sample's equilibrium (`EquilibriumSolver.solve`).

    Attributes:
        q: Joint positions at equilibrium [rad], shape (nq,).
        iterations: Newton iterations used (summed over the friction rounds).
        jac: Translational Jacobian of the tool tip at the last iteration, sheet frame [m/rad], shape (3, nv).
        stiffness: The sheet's df/dp at the last iteration [N/m], shape (3, 3).
    """

    q: np.ndarray
    iterations: int
    jac: np.ndarray
    stiffness: np.ndarray


class NewtonResult(NamedTuple):
    """One Newton solve (`EquilibriumSolver._newton`): the equilibrium, and what the friction rounds need.

    Attributes:
        q, iterations, jac, stiffness: As `Equilibrium` (for this solve alone).
        demand: The demanded joint torque g - J^T f at the equilibrium [N·m], shape (nv,).
        stuck: The stuck joints of the solve, shape (nv,) bool (a placeholder without friction).
        tau_fr: The friction torques of the slipping joints [N·m], shape (nv,) (a placeholder without friction).
    """

    q: np.ndarray
    iterations: int
    jac: np.ndarray
    stiffness: np.ndarray
    demand: np.ndarray
    stuck: np.ndarray
    tau_fr: np.ndarray


class EquilibriumSolver:
    """Newton's method on the equilibrium of one model's joints, with an active set for joint friction.

    Args:
        model: The twin's compiled model (position actuators as springs, `frictionloss`, site `tcp`); shared
            with the twin, so changes of its springs or friction apply.
        data: Its data; qpos and the kinematics are overwritten.
        tcp_site: Id of the `tcp` site.
        p_base_sheet_origin: Sheet origin in the base frame [m], shape (3,).
        R_base_sheet: Orientation of the sheet frame in the base (3, 3); None: the base axes. The sheet model
            sees the tool tip, and the Newton iteration the Jacobian, in the sheet frame.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        tcp_site: int,
        p_base_sheet_origin: np.ndarray,
        R_base_sheet: np.ndarray | None = None,
    ) -> None:
        self.model, self.data = model, data
        self._tcp = tcp_site
        self.p_base_sheet_origin = p_base_sheet_origin
        self.R_base_sheet = None if R_base_sheet is None or np.array_equal(R_base_sheet, np.eye(3)) else R_base_sheet

    #: Choose the first stick/slip set from the friction torque needed at the start point (the first Newton
    #: iteration's own evaluation) instead of starting with every frictional joint stuck: one active-set round
    #: instead of two on the groove, the same consistent set, the same equilibrium (tests/test_speed_equilibrium.py).
    predict_active_set: bool = True

    def _newton(
        self,
        q: np.ndarray,
        q_ref: np.ndarray,
        k_diag: np.ndarray,
        h_const: np.ndarray,
        sheet: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
        stick: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
        choose_tau_f: np.ndarray | None = None,
    ) -> NewtonResult:
        """Newton's method on K (q_ref - q) + τ_fr - g(q) + J_tcp(q)^T f(p(q)) = 0 from `q`.

        Args:
            q: Start [rad], shape (nq,).
            q_ref: Spring references (set-points taught under gravity) [rad], shape (nq,).
            k_diag: Joint springs [N·m/rad], shape (nv,).
            h_const: K + dg/dq, the Newton matrix without the sheet term, shape (nv, nv).
            sheet: Tool-tip position in the sheet frame [m] -> (force on the tool [N], df/dp [N/m]).
            stick: None (no friction), or (stuck, e_stuck, tau_fr): dofs whose elastic deflection q_ref - q is
                held at e_stuck [rad] (the joint sticks), and the friction torque of the slipping ones [N·m].
            choose_tau_f: Friction torques τ_f [N·m]: replace `stick`'s set by the one the start point asks
                for (stuck where the needed friction |g - J^T f - K e_stuck| <= τ_f, else slipping with
                τ_f·sign of it), from the first iteration's evaluation; None keeps `stick`.

        Returns:
            The solve (`NewtonResult`).
        """
        m, d = self.model, self.data
        jacp = np.zeros((3, m.nv))
        g = np.zeros(m.nv)
        xpos_tcp = d.site_xpos[self._tcp]  # a view: follows every mj_kinematics
        qpos, tcp, origin, rot = d.qpos, self._tcp, self.p_base_sheet_origin, self.R_base_sheet
        kinematics, com_pos, rne, jac_site = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_rne, mujoco.mj_jacSite
        # r = base - K q + free (J^T f - g), and the stuck rows of h replaced by those of diag(K)
        base = k_diag * q_ref
        stuck = tau_fr = free = stuck_idx = stuck_rows = base  # set on the first iteration when `stick` is given
        k = 0
        for k in range(1, NEWTON_MAX_ITER + 1):
            qpos[:] = q
            kinematics(m, d)
            com_pos(m, d)
            rne(m, d, 0, g)
            jac_site(m, d, jacp, None, tcp)
            if rot is None:
                force, stiffness = sheet(xpos_tcp - origin)
            else:  # the tip and the Jacobian in the sheet frame (the sheet model's own)
                force, stiffness = sheet(rot.T @ (xpos_tcp - origin))
                jacp[:] = rot.T @ jacp
            jtf = jacp.T @ force
            if stick is None:
                r = base - k_diag * q + (jtf - g)
                h = h_const - jacp.T @ stiffness @ jacp
            else:
                if k == 1:
                    stuck, e_stuck, tau_fr = stick
                    if choose_tau_f is not None:
                        need = g - jtf - k_diag * e_stuck
                        stuck = (choose_tau_f > 0.0) & (np.abs(need) <= choose_tau_f)
                        tau_fr = np.where(stuck, 0.0, choose_tau_f * np.sign(need))
                    base = np.where(stuck, k_diag * (q_ref - e_stuck), base + tau_fr)
                    free = (~stuck).astype(float)
                    stuck_idx = np.flatnonzero(stuck)
                    stuck_rows = np.diag(k_diag)[stuck_idx]
                r = base - k_diag * q + free * (jtf - g)
                h = h_const - jacp.T @ stiffness @ jacp
                if stuck_idx.size:
                    h[stuck_idx] = stuck_rows
            _, _, dq, info = _dgesv(h, r)  # np.linalg.solve costs 5x more
            if info != 0:
                raise np.linalg.LinAlgError(f"singular Newton matrix (LAPACK dgesv info {info}) at q = {q!r}")
            if k > NEWTON_DAMPED_AFTER:  # cycling across a kink of the sheet's force law: damped steps
                dq *= 0.5
            q = q + dq
            if abs(dq).max() < NEWTON_TOL_RAD:
                break
        return NewtonResult(q, k, jacp, stiffness, g - jacp.T @ force, stuck, tau_fr)

    def solve(
        self,
        q: np.ndarray,
        q_ref: np.ndarray,
        k_diag: np.ndarray,
        h_const: np.ndarray,
        sheet: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
        e_prev: np.ndarray,
        hold: bool = True,
    ) -> Equilibrium:
        """Equilibrium with joint friction: stick/slip per joint, found by an active set.

        Coulomb friction τ_f in a joint acts on the link against its motion. A joint sticks, its link where
        it was, while the torque the friction must add, |D - K e_prev| with D = g - J^T f and e_prev = q_ref -
        q_link_prev, stays within τ_f; beyond, it slips and its spring carries K e = D - τ_f·sign(D - K e_prev).
        Starting with every frictional joint stuck, joints whose needed friction exceeds τ_f slip, and slipping
        joints that would move against their friction stick again, until the set is consistent (a few rounds
        at most). With `predict_active_set` (default) the first set is the one the start point asks for, with
        every frictional link held where it was (the point the all-stuck round would restart from): one round
        instead of two on the groove (3.0 instead of 5.0 Newton iterations per sample), the same equilibria.
        With `hold` False (a force model that declares `extrapolated_start`, the ISF model) the frictional
        joints start from the extrapolated deflection too and the set is chosen there: about 1.9 instead of
        3.6 iterations per sample on a cone; on the groove's table field that start lands on another
        equilibrium branch 0.9 mm away near the end walls of pass 9, so that field holds the links.

        Args:
            q, q_ref, k_diag, h_const, sheet: As for `_newton`.
            e_prev: Spring stretch q_ref - q_link_prev that keeps each link where it was [rad], shape (nv,).
            hold: With `predict_active_set`, start the frictional joints where their links are held (False: from
                `q`, the extrapolated start).

        Returns:
            The equilibrium; iterations summed over the rounds.
        """
        tau_f = self.model.dof_frictionloss
        frictional = tau_f > 0.0
        if not frictional.any():
            solved = self._newton(q, q_ref, k_diag, h_const, sheet)
            return Equilibrium(solved.q, solved.iterations, solved.jac, solved.stiffness)
        stuck, tau_fr = frictional, np.zeros(len(tau_f))  # every frictional link holds (never changed in place)
        total = 0
        choose = None
        if self.predict_active_set:  # the set is chosen where every frictional joint still holds its link
            choose = tau_f
            if hold:
                q = np.where(frictional, q_ref - e_prev, q)
        for _ in range(FRICTION_MAX_ROUNDS):
            q, k, jac, s, demand, stuck, tau_fr = self._newton(
                q, q_ref, k_diag, h_const, sheet, (stuck, e_prev, tau_fr), choose
            )
            choose = None
            total += k
            need = demand - k_diag * e_prev
            slip = stuck & (np.abs(need) > tau_f)
            # a slipping joint whose link moved against its friction (tau_fr is 0 on frictionless joints)
            back = ~stuck & ((q_ref - q - e_prev) * tau_fr < 0.0)
            if not (slip.any() or back.any()):
                break
            stuck = (stuck & ~slip) | back
            tau_fr = np.where(slip, tau_f * np.sign(need), np.where(back, 0.0, tau_fr))
        return Equilibrium(q, total, jac, s)
