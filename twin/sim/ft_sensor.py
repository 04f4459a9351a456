"""The flange force/torque sensor of the twin: the robot's MuJoCo force sensor read along a simulated run."""

from __future__ import annotations

import mujoco
import numpy as np

from twin.base.signals import interp_rows
from twin.robot.facts import RobotDescription
from twin.sim.result import SimResult


def flange_sensor_forces(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    result: SimResult,
    t_s: np.ndarray,
    *,
    robot: RobotDescription,
    full_inverse: bool = False,
    R_base_sheet: np.ndarray | None = None,
) -> np.ndarray:
    """Read MuJoCo's flange force sensor at the given times, as the run format wants it.

    The equilibrium joint positions and the sheet force are interpolated to `t_s` (the force by
    `SimResult.force_at`: across a pass change of the per-pass table field it steps); the force is applied
    at the tool tip (`xfrc_applied` on the tool body, moment carried to its centre of mass); `mj_inverse`
    at qvel = qacc = 0 evaluates the `ft_force` sensor; the tool's weight is removed by a second, unloaded
    reading at the same pose (tare); the result is turned into the sheet frame and its sign flipped
    (the sensor reports the force the sensor body exerts on the tool).

    At rest (qvel = qacc = 0) the sensor needs only the stages of `mj_inverse` that feed it: positions
    (`mj_kinematics`, `mj_comPos`), then the interaction forces (`mj_rnePostConstraint`) and the sensor
    (`mj_sensorAcc`); one `mj_forward` first zeroes the velocity-stage quantities. This reads what
    `mj_inverse` reads to 1e-10 N at 60 % of its cost (tests/test_sim.py holds the two together).

    Args:
        model: The model `result` was simulated with (the robot's tool site, F/T site and force sensor).
        data: Its data; qpos, qvel, qacc and xfrc_applied are overwritten.
        result: A run from `Twin.simulate`.
        t_s: Sensor sample times [s], within the run.
        robot: The robot (its tool site, F/T site and force sensor).
        full_inverse: Evaluate each reading with the whole `mj_inverse` (the reference of the lighter path).
        R_base_sheet: Orientation of the sheet frame in the base (the placement's yaw); None: the base axes.

    Returns:
        Force exerted by the sheet on the tool, sheet frame [N], shape (m, 3).
    """
    m, d = model, data
    tcp = m.site(robot.tool_site).id
    tool_body = int(m.site_bodyid[tcp])
    ft_site = m.site(robot.ft_site).id
    t_s = np.asarray(t_s, dtype=float)
    qpos = interp_rows(t_s, result.t_s, result.qpos)
    force = result.force_at(t_s)  # steps at the reversals with the per-pass table field
    rot = np.eye(3) if R_base_sheet is None else np.asarray(R_base_sheet, dtype=float)
    force = force @ rot.T  # base frame
    sensor_adr = m.sensor(robot.ft_force_sensor).adr[0]
    # views into MjData, refreshed by every mj_kinematics / mj_inverse
    sensor = d.sensordata[sensor_adr : sensor_adr + 3]
    R_base_ft = d.site_xmat[ft_site].reshape(3, 3)
    wrench = d.xfrc_applied[tool_body]
    tcp_xpos, tool_xipos = d.site_xpos[tcp], d.xipos[tool_body]
    d.qvel[:] = 0.0
    d.qacc[:] = 0.0
    d.xfrc_applied[:] = 0.0
    if not full_inverse:
        mujoco.mj_forward(m, d)  # velocity-dependent quantities (cvel, cdof_dot) at qvel = 0, contacts
    kinematics, com_pos, post, sensor_acc, inverse = (
        mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_rnePostConstraint, mujoco.mj_sensorAcc, mujoco.mj_inverse
    )
    def read() -> None:  # the sensor at the current pose and wrench
        if full_inverse:
            inverse(m, d)
        else:
            post(m, d)
            sensor_acc(m, d)

    n = len(t_s)
    loaded, tare, R_all = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3, 3))
    qpos_view, forces = d.qpos, force.tolist()
    for i in range(n):
        qpos_view[:] = qpos[i]
        kinematics(m, d)
        if not full_inverse:
            com_pos(m, d)
        l0, l1, l2 = (tcp_xpos - tool_xipos).tolist()
        a0, a1, a2 = forces[i]
        wrench[:] = (a0, a1, a2, l1 * a2 - l2 * a1, l2 * a0 - l0 * a2, l0 * a1 - l1 * a0)  # lever x force
        read()
        loaded[i] = sensor
        wrench[:] = 0.0  # the tare: the same pose unloaded
        read()
        tare[i] = sensor
        R_all[i] = R_base_ft
    out = -np.einsum("nij,nj->ni", R_all, loaded - tare)
    return out @ rot  # sheet frame
