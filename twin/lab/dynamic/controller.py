"""A CS8C-class joint position controller for the dynamic plant.

A Stäubli CS8C closes position and velocity loops on the motor encoders (the link side is not measured), with
velocity and torque feed-forward from its trajectory generator, which interpolates the programmed path every
4 ms. Here, per joint and per servo tick (one MuJoCo step):

    tau = kp (q_sp - q_m) + kv (dq_sp - dq_m) + ki * integral(q_sp - q_m) + g(q_sp) + J ddq_sp,

with q_m the motor-side hinge, q_sp the motor set-point, g the gravity torque at the commanded pose and J ddq_sp
the inertia torque of the set-point (torque feed-forward, on the same diagonal J the gains are designed on).
kp and kv are those of a MuJoCo position servo on the motor hinge (its kv term is integrated implicitly); the
integral, velocity, gravity and inertia terms enter through `ctrl`.

Gains from a stated design rule, a cascade tuned as a drive's autotune tunes it, not from any replay:

* the joint's first structural mode f_s = sqrt(K_q/J)/2 pi, the link on its gear spring (J = motor armature +
  the rigid arm's mass-matrix diagonal at the start pose);
* position-loop bandwidth f_p = r f_s, r = `servo_bandwidth_over_mode` (0.5: an octave below the first
  mechanical resonance, within the 5-20 Hz usual for the main axes of industrial arms);
* the velocity loop and the position integrator from f_p and the damping factor zeta (`servo_damping_ratio`,
  0.8) by Rockwell Automation's single-knob tuning rules (publication MOTION-RM003I-EN-P, Feb 2018, pp. 259-260,
  "System Bandwidth", Position Loop operation: velocity-loop bandwidth = 4 zeta^2 x position-loop bandwidth,
  position integrator bandwidth = 0.25/zeta^2 x position-loop bandwidth; damping factor default 0.8,
  1784-UM003A-EN-P p. 124): w_v = 4 zeta^2 w_p, w_pi = w_p / (4 zeta^2);
* the cascade written as one PID: velocity command w_p (e + w_pi integral(e)) + dq_sp, torque J w_v times the
  velocity error, so kv = J w_v, kp = kv w_p, ki = kp w_pi. The closed loop J s^2 + kv s + kp has natural
  frequency 2 zeta w_p and damping ratio zeta.

With the plant's own K_q (`plant_robots.py`) the TX200's position-loop bandwidths come out at 6-12 Hz for
joints 1-3 and 26-38 Hz for the wrist, kp = 0.64 K_q on every joint (docs/dynamic-plant.md's table, held by
tests/test_plant.py).

Set-points are taught under gravity, as the twin teaches them: the motor set-point is
q_sp = q_ik + g(q_ik)/K_q + sign(g) b/2, so the unloaded robot (gear spring wound up by gravity, dead band
closed on the gravity side) lands on the rigid IK solution q_ik.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.plant import Plant
from twin.robot.facts import RobotDescription


@dataclass(frozen=True)
class ServoGains:
    """Gains of the arm joints.

    Attributes:
        kp: Proportional gain [N·m/rad], shape (dof,).
        kv: Velocity gain [N·m·s/rad], shape (dof,).
        ki: Integral gain [N·m/(rad s)], shape (dof,).
        inertia: Inertia J the gains were designed on [kg m²], shape (dof,).
        mode_hz: First structural mode sqrt(K_q/J)/2 pi of each joint [Hz], shape (dof,).
    """

    kp: np.ndarray
    kv: np.ndarray
    ki: np.ndarray
    inertia: np.ndarray
    mode_hz: np.ndarray

    @property
    def position_hz(self) -> np.ndarray:
        """Position-loop bandwidth kp/kv/2 pi [Hz], shape (dof,)."""
        return self.kp / self.kv / (2.0 * np.pi)


def gravity_torques(rigid: mujoco.MjModel, q: np.ndarray, robot: RobotDescription) -> np.ndarray:
    """Gravity torques g(q) of the rigid arm (MuJoCo bias at rest) [N·m], shape (n, dof) for q (n, dof)."""
    arm = robot.addresses(rigid)
    data = mujoco.MjData(rigid)
    out = np.zeros((len(q), robot.dof))
    bias = np.zeros(rigid.nv)
    for i, qi in enumerate(q):
        data.qpos[arm.qpos] = qi
        data.qvel[:] = 0.0
        mujoco.mj_kinematics(rigid, data)
        mujoco.mj_comPos(rigid, data)
        mujoco.mj_rne(rigid, data, 0, bias)
        out[i] = bias[arm.dof]
    return out


def design_gains(plant: Plant, rigid: mujoco.MjModel, q0: np.ndarray, knobs: Knobs) -> ServoGains:
    """Gains by the design rule (module docstring) from the arm's inertia at `q0` [rad] and the gear's K_q."""
    arm = plant.robot.addresses(rigid)
    data = mujoco.MjData(rigid)
    data.qpos[arm.qpos] = q0
    mujoco.mj_forward(rigid, data)
    mass = np.zeros((rigid.nv, rigid.nv))
    mujoco.mj_fullM(rigid, data, mass)
    rigid_arm = rigid.dof_armature[arm.dof]
    inertia = plant.motor_armature + np.diag(mass)[arm.dof] - rigid_arm
    mode_hz = np.sqrt(plant.k_q / inertia) / (2.0 * np.pi)
    zeta2 = knobs["servo_damping_ratio"] ** 2
    w_p = 2.0 * np.pi * knobs["servo_bandwidth_over_mode"] * mode_hz
    w_v = 4.0 * zeta2 * w_p
    kv = inertia * w_v
    kp = kv * w_p
    return ServoGains(kp=kp, kv=kv, ki=kp * w_p / (4.0 * zeta2), inertia=inertia, mode_hz=mode_hz)


def _moving_average(values: np.ndarray, width: int) -> np.ndarray:
    """Centred moving average over `width` rows (odd), ends held."""
    if width <= 1:
        return values
    half = width // 2
    padded = np.concatenate([np.repeat(values[:1], half, 0), values, np.repeat(values[-1:], half, 0)])
    csum = np.cumsum(padded, axis=0)
    csum = np.concatenate([np.zeros((1, values.shape[1])), csum])
    return (csum[width:] - csum[:-width]) / width


def servo_setpoints(
    t_cmd_s: np.ndarray,
    q_ik: np.ndarray,
    g_ik: np.ndarray,
    plant: Plant,
    knobs: Knobs,
    t_servo_s: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motor set-points at the servo ticks, through the trajectory generator.

    Args:
        t_cmd_s: Commanded sample times [s], shape (n,).
        q_ik: Rigid IK of the commanded path [rad], shape (n, dof).
        g_ik: Gravity torques at q_ik [N·m], shape (n, dof).
        plant: The plant (K_q, dead bands).
        knobs: Trajectory period and smoothing.
        t_servo_s: Servo tick times [s], shape (m,).

    Returns:
        Motor set-point [rad], its rate [rad/s] and the gravity feed-forward [N·m], each shape (m, dof).
    """
    q_sp = q_ik + g_ik / plant.k_q + np.sign(g_ik) * plant.backlash_rad / 2.0
    period = knobs["trajectory_period_s"]
    t_traj = np.arange(0.0, t_servo_s[-1] + period, period)
    traj = np.column_stack([np.interp(t_traj, t_cmd_s, q_sp[:, j]) for j in range(plant.dof)])
    width = round(knobs["trajectory_smoothing_s"] / period) | 1
    traj = _moving_average(traj, width)
    q_servo = np.column_stack([np.interp(t_servo_s, t_traj, traj[:, j]) for j in range(plant.dof)])
    dq_servo = np.gradient(q_servo, t_servo_s, axis=0)
    g_servo = np.column_stack([np.interp(t_servo_s, t_cmd_s, g_ik[:, j]) for j in range(plant.dof)])
    return q_servo, dq_servo, g_servo


def setpoint_acceleration(dq_servo: np.ndarray, t_servo_s: np.ndarray, period_s: float) -> np.ndarray:
    """Set-point acceleration [rad/s²], (m, dof), averaged over one trajectory period (the rate of a piecewise
    linear set-point steps at each trajectory point), for the torque feed-forward J·q̈_sp."""
    dt = float(t_servo_s[1] - t_servo_s[0]) if len(t_servo_s) > 1 else period_s
    ddq = np.gradient(dq_servo, t_servo_s, axis=0) if len(t_servo_s) > 1 else np.zeros_like(dq_servo)
    return _moving_average(ddq, round(period_s / dt) | 1)


def rest_state(plant: Plant, q_link: np.ndarray, g: np.ndarray) -> np.ndarray:
    """qpos of the unloaded arm at rest on `q_link` [rad] with gravity torques `g` [N·m] (all hinges)."""
    qpos = np.zeros(plant.model.nq)
    gear = (
        -g / plant.k_q - np.sign(g) * plant.backlash_rad / 2.0
    )  # spring wound up, flank on the gravity side
    qpos[plant.link_qpos] = gear
    qpos[plant.motor_qpos] = q_link - gear
    return qpos


def apply_gains(plant: Plant, gains: ServoGains) -> None:
    """Write kp and kv into the motor servos (gain kp, bias -kp q - kv dq)."""
    m = plant.model
    for j, act in enumerate(plant.servo):
        m.actuator_gaintype[act] = mujoco.mjtGain.mjGAIN_FIXED
        m.actuator_biastype[act] = mujoco.mjtBias.mjBIAS_AFFINE
        m.actuator_gainprm[act, :] = 0.0
        m.actuator_biasprm[act, :] = 0.0
        m.actuator_gainprm[act, 0] = gains.kp[j]
        m.actuator_biasprm[act, 1] = -gains.kp[j]
        m.actuator_biasprm[act, 2] = -gains.kv[j]
