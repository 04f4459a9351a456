"""A gear's play under the forming load: the flank each arm joint rests on (the effect `Effects.gear_play_rad`).

The dead-zone backlash of the control literature (Nordin & Gutman 2002, "Controlling mechanical systems with
backlash - a survey", Automatica 38(10), 1633-1649): the link lags the motor by -b s(tau), b the half dead band
and s a smooth sign of the torque the gear transmits,

    tau = g(q) - J^T F + FRICTION_SHARE x f_c x sign(dq/dt),

gravity's torque (the twin's own MuJoCo model), the forming force's moment and the link side's friction. The robot
is calibrated and taught under gravity, so the flank gravity alone sets is the reference: the offset is
-b (s(tau) - s(g)) (`load_flank`). Where gravity's torque is large and one-signed the play hardly shows; where the
forming force's moment outweighs it, or on a joint gravity does not load, it flips with the load.

The twin (`twin.sim.quasi_static.Twin.simulate`) replays once, takes the flanks from that replay's torques and
replays again with -b x flank added to the arm joints' references (`gear_play_references`); the discrepancy
family `lost_motion_under_load` fits b with the same flanks, so what it finds is what the twin carries.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from twin.robot.model import lost_motion_schedule

if TYPE_CHECKING:
    from twin.sim.quasi_static import Twin

#: The take-up torque of s = tanh(tau / tau_0), as a share of the joint torque's swing along the run: the flank
#: change of a real gear is spread by its elasticity and friction (the twin's path rarely crosses zero torque
#: sharply), and a share keeps the effect linear in b and free of robot-specific torques.
TAKEUP_SHARE = 0.05
#: The share of the twin's joint friction the gear transmits (the link side's bearings; the motor's own friction
#: acts before the gear): the flank under a light load follows the joint's motion through it.
FRICTION_SHARE = 0.5
#: Poses along the run at which gravity's torque is evaluated (interpolated between; it varies slowly).
GRAVITY_POSES = 200


def gravity_torque(twin: Twin, t_s: np.ndarray, qpos: np.ndarray) -> np.ndarray:
    """Gravity's torque on the arm joints along a replay [N·m], shape (n, dof).

    Args:
        twin: The twin (its own MuJoCo model, `mj_rne` without velocity or acceleration).
        t_s: Sample times [s], shape (n,).
        qpos: The twin's (loaded) poses [rad], shape (n, nq).
    """
    model = twin.model
    data = mujoco.MjData(model)
    dof = twin.robot.addresses(model).dof
    rows = np.unique(np.r_[np.arange(0, len(t_s), max(1, len(t_s) // GRAVITY_POSES)), len(t_s) - 1])
    out = np.zeros((len(rows), len(dof)))
    bias = np.zeros(model.nv)
    for k, i in enumerate(rows):
        data.qpos[:] = qpos[i]
        data.qvel[:] = 0.0
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_rne(model, data, 0, bias)
        out[k] = bias[dof]
    return np.column_stack([np.interp(t_s, t_s[rows], out[:, j]) for j in range(out.shape[1])])


def load_flank(
    twin: Twin, t_s: np.ndarray, p_cmd_sheet_m: np.ndarray, direction: np.ndarray, q_ik: np.ndarray,
    qpos: np.ndarray, f_sheet_n: np.ndarray,
) -> np.ndarray:
    """s(tau) - s(g) of the arm joints along a replay [-], shape (n, dof) (module docstring).

    s = tanh(tau / tau_0), tau_0 = TAKEUP_SHARE x the swing of the joint's torque along the run.

    Args:
        twin: The twin that made the replay (model, kinematics, placement, joint friction, lost-motion take-up).
        t_s: Sample times [s], shape (n,).
        p_cmd_sheet_m: Commanded tool tip, sheet frame [m], shape (n, 3).
        direction: Travel direction along x per sample (+1/-1), shape (n,).
        q_ik: Rigid IK of the command [rad], shape (n, dof).
        qpos: The replay's loaded poses (all joints) [rad], shape (n, nq).
        f_sheet_n: Force of the sheet on the tool, sheet frame [N], shape (n, 3).
    """
    gravity = gravity_torque(twin, t_s, qpos)
    jac = twin.kinematics.jacobians(qpos[:, twin.robot.addresses(twin.model).qpos])[:, :3, :]
    force_base = f_sheet_n @ twin.R_base_sheet.T
    # the joint's motion, +/-1: the travel direction (ramped after reversals) x sign(d x_sheet / dq) at the start
    level = -lost_motion_schedule(p_cmd_sheet_m[:, 0], direction, np.ones(1), 1.0,
                                  twin.effects.lost_motion_takeup_m)[:, 0]
    dx_dq = twin.R_base_sheet[:, 0] @ twin.kinematics.jacobian(q_ik[0])[:3]
    moving = level[:, None] * np.where(np.abs(dx_dq) > 1e-3, np.sign(dx_dq), 1.0)[None, :]
    friction = FRICTION_SHARE * twin.joint_friction[None, :] * moving
    tau = gravity - np.einsum("nij,ni->nj", jac, force_base) + friction
    takeup = np.maximum(TAKEUP_SHARE * np.ptp(tau, axis=0), 1e-9)
    return np.tanh(tau / takeup) - np.tanh(gravity / takeup)


def gear_play_references(
    twin: Twin, q_nominal_all: np.ndarray, t_s: np.ndarray, p_cmd_sheet_m: np.ndarray, direction: np.ndarray,
    qpos: np.ndarray, f_sheet_n: np.ndarray,
) -> np.ndarray:
    """The spring references of a replay with the twin's gear play: -b x the flank of the first replay added to
    the arm joints' [rad], shape (n, nq) (a copy of `q_nominal_all`, whose arm columns are the rigid IK).

    Args:
        twin: The twin; its `effects.gear_play_rad` gives b per arm joint [rad].
        q_nominal_all: The first replay's unloaded poses (all joints) [rad], shape (n, nq).
        t_s, p_cmd_sheet_m, direction: The command (`load_flank`).
        qpos, f_sheet_n: The first replay's loaded poses [rad] and sheet force [N] (`load_flank`).
    """
    arm = twin.robot.addresses(twin.model).qpos
    flank = load_flank(twin, t_s, p_cmd_sheet_m, direction, q_nominal_all[:, arm], qpos, f_sheet_n)
    out = q_nominal_all.copy()
    out[:, arm] -= np.asarray(twin.effects.gear_play_rad, dtype=float)[None, :] * flank
    return out
