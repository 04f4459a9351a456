"""A gear's play under the forming load: the flank each arm joint rests on (the effect `Effects.gear_play_rad`).

The dead-zone backlash of the control literature (Nordin & Gutman 2002, "Controlling mechanical systems with
backlash - a survey", Automatica 38(10), 1633-1649): the link lags the motor by -b s(tau), b the half dead band
and s a smooth sign of the torque the gear transmits,

    tau = g(q) + M(q) q'' + c(q, q') - J^T F + FRICTION_SHARE x f_c x sign(q'),

the torque that holds and moves the links along the command (inverse dynamics of the twin's own MuJoCo model,
without the motors' armature, which acts before the gear), the forming force's moment and the link side's
friction, which opposes each joint's own motion (`joint_motion`). The robot is calibrated and taught under
gravity, so the flank gravity alone sets is the reference: the offset is -b (s(tau) - s(g)) (`load_flank`). Where
gravity's torque is large and one-signed the play hardly shows; where the forming force's moment outweighs it, or
on a joint gravity does not load (a vertical axis, where a link's inertia turns the flank before the joint
reverses), it flips with the load.

The twin (`twin.sim.quasi_static.Twin.simulate`) replays once, takes the flanks from that replay's torques and
replays again with -b x flank added to the arm joints' references (`gear_play_references`); the discrepancy
family `lost_motion_under_load` fits b with the same flanks, so what it finds is what the twin carries.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np
from scipy.ndimage import uniform_filter1d

if TYPE_CHECKING:
    from twin.sim.quasi_static import Twin

#: The take-up torque of s = tanh(tau / tau_0), as a share of the joint torque's swing along the run: the flank
#: change of a real gear is spread by its elasticity and friction (the twin's path rarely crosses zero torque
#: sharply), and a share keeps the effect linear in b and free of robot-specific torques.
TAKEUP_SHARE = 0.05
#: The share of the twin's joint friction the gear transmits (the link side's bearings; the motor's own friction
#: acts before the gear): the flank under a light load follows the joint's motion through it.
FRICTION_SHARE = 0.5
#: A joint slower than this is standing still [rad/s] (0.1 mm/s at 1 m of reach).
MOVING_RAD_PER_S = 1e-4
#: Poses along the run at which the links' torque is evaluated (interpolated between).
GRAVITY_POSES = 1000
#: The window the commanded joint speed is averaged over before its acceleration is taken [s] (the controller's
#: own trajectory is smoother than its sampled command).
ACCELERATION_WINDOW_S = 0.1


def rne_along(model: mujoco.MjModel, t_s: np.ndarray, qpos: np.ndarray, dof: np.ndarray | None = None,
              speed: np.ndarray | None = None, acceleration: np.ndarray | None = None) -> np.ndarray:
    """The torque that holds the model's links at `qpos` (gravity) and, where given, moves the dofs `dof` at
    `speed` and `acceleration` (inertia, Coriolis), `mj_rne` at GRAVITY_POSES poses interpolated between [N·m],
    shape (n, nv); the motors' armature is not in it.

    Args:
        model: A MuJoCo model (the twin's own).
        t_s: Sample times [s], shape (n,).
        qpos: Poses [rad], shape (n, nq).
        dof: The dofs `speed` and `acceleration` give [-]; None: none move.
        speed, acceleration: Their speed [rad/s] and acceleration [rad/s²], shape (n, len(dof)).
    """
    data = mujoco.MjData(model)
    rows = np.unique(np.r_[np.arange(0, len(t_s), max(1, len(t_s) // GRAVITY_POSES)), len(t_s) - 1])
    out = np.zeros((len(rows), model.nv))
    for k, i in enumerate(rows):  # bounded: GRAVITY_POSES poses
        data.qpos[:], data.qvel[:], data.qacc[:] = qpos[i], 0.0, 0.0
        if dof is not None and speed is not None and acceleration is not None:
            data.qvel[dof], data.qacc[dof] = speed[i], acceleration[i]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_comVel(model, data)
        mujoco.mj_rne(model, data, 1, out[k])
    return np.column_stack([np.interp(t_s, t_s[rows], out[:, j]) for j in range(model.nv)])


def link_torque(twin: Twin, t_s: np.ndarray, qpos: np.ndarray, q_ik: np.ndarray | None = None) -> np.ndarray:
    """Gravity's torque on the arm joints along a replay, with the torque that moves the links where `q_ik` is
    given (inverse dynamics of the commanded motion, `rne_along`) [N·m], shape (n, dof).

    Args:
        twin: The twin (its own MuJoCo model).
        t_s: Sample times [s], shape (n,).
        qpos: The twin's (loaded) poses [rad], shape (n, nq).
        q_ik: The commanded joint motion [rad], shape (n, dof), its speed and acceleration (averaged over
            ACCELERATION_WINDOW_S) giving the links' inertia and Coriolis torques; None: gravity alone.
    """
    dof = twin.robot.addresses(twin.model).dof
    if q_ik is None or len(t_s) <= 2:
        return rne_along(twin.model, t_s, qpos)[:, dof]
    speed = np.gradient(q_ik, t_s, axis=0)
    window = max(1, round(ACCELERATION_WINDOW_S / max(float(np.median(np.diff(t_s))), 1e-6)))
    acceleration = np.gradient(uniform_filter1d(speed, window, axis=0), t_s, axis=0)
    return rne_along(twin.model, t_s, qpos, dof, speed, acceleration)[:, dof]


def joint_motion(t_s: np.ndarray, q_ik: np.ndarray) -> np.ndarray:
    """The sign of each arm joint's speed along the command, +/-1, held through the stops [-], shape (n, dof).

    The link side's friction opposes the link's motion, so the gear transmits it with the sign of the joint's own
    speed (the rigid IK's): on a groove the travel direction along x, on a cone a joint that swings once a lap.
    Where a joint stands still (a stop, or a joint the path does not move) the last sign holds.
    """
    speed = np.gradient(q_ik, t_s, axis=0)
    moving = np.abs(speed) > MOVING_RAD_PER_S
    rows = np.arange(len(speed))[:, None]
    last = np.maximum.accumulate(np.where(moving, rows, -1), axis=0)  # the last moving sample, -1 before any
    first = np.where(moving.any(axis=0), np.argmax(moving, axis=0), -1)  # before it moves: its first motion's
    held = np.where(last >= 0, last, first[None, :])
    cols = np.arange(speed.shape[1])[None, :]
    return np.where(held >= 0, np.sign(speed[np.maximum(held, 0), cols]), 1.0)


def load_flank(
    twin: Twin, t_s: np.ndarray, q_ik: np.ndarray, qpos: np.ndarray, f_sheet_n: np.ndarray,
) -> np.ndarray:
    """s(tau) - s(g) of the arm joints along a replay [-], shape (n, dof) (module docstring).

    s = tanh(tau / tau_0), tau_0 = TAKEUP_SHARE x the swing of the joint's torque along the run.

    Args:
        twin: The twin that made the replay (model, kinematics, placement, joint friction).
        t_s: Sample times [s], shape (n,).
        q_ik: Rigid IK of the command [rad], shape (n, dof) (the joints' motion, `joint_motion`).
        qpos: The replay's loaded poses (all joints) [rad], shape (n, nq).
        f_sheet_n: Force of the sheet on the tool, sheet frame [N], shape (n, 3).
    """
    gravity = link_torque(twin, t_s, qpos)
    links = link_torque(twin, t_s, qpos, q_ik)
    jac = twin.kinematics.jacobians(qpos[:, twin.robot.addresses(twin.model).qpos])[:, :3, :]
    force_base = f_sheet_n @ twin.R_base_sheet.T
    moving = joint_motion(t_s, q_ik)
    friction = FRICTION_SHARE * twin.joint_friction[None, :] * moving
    tau = links - np.einsum("nij,ni->nj", jac, force_base) + friction
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
    flank = load_flank(twin, t_s, q_nominal_all[:, arm], qpos, f_sheet_n)
    out = q_nominal_all.copy()
    out[:, arm] -= np.asarray(twin.effects.gear_play_rad, dtype=float)[None, :] * flank
    return out
