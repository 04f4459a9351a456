"""The dynamic plant's MuJoCo model: each arm joint as a motor side and a gear (spring with a dead band).

Built with `mujoco.MjSpec` from the robot's cell scene (`RobotDescription.scene`), so masses, armature, damping
time and friction follow the model file; the gear stiffness K_q does not (the plant's own, `plant_robots.py`).
Each link body gets two hinges on the same axis and point:

* `<joint>_motor`: the motor side. Armature = the shipped joint's armature (reflected rotor inertia),
  `damping` = viscous friction and `frictionloss` = Coulomb friction of the motor and gearbox input (knobs).
  Driven by actuator `<joint>_servo`, a MuJoCo
  position servo (force = kp (ctrl - q) - kv q_dot) whose kv term `implicitfast` integrates implicitly; the
  controller (`controller.py`) writes its set-point, integral and feed-forward into `ctrl`.
* `<joint>` (the shipped hinge): the gear, link angle minus motor angle. Its torque is the gear's
  torsional spring K_q,i, the PLANT'S OWN (`plant_robots.py`: an absolute table per shipped robot, 0.72-1.38x
  the twin's prior joint by joint, times the knobs `gear_stiffness_j<i>_scale`; not the joint's
  position-actuator gain, which is the twin's prior) acting through a dead band
  of width b: tau = -K_q dz(q_gear), dz(x) = sign(x) max(|x| - b/2, 0): no torque while the teeth float in the
  gap, the spring once they touch either flank. With b = 0 it is MuJoCo's own joint `stiffness`; with b > 0
  the simulation loop applies it each step (`gear_torques` into `qfrc_applied`), like the native spring an
  explicit force. Damping = the plant's K_q times the shipped model's damping time (damping / gain, 0.01 s),
  armature `gear_armature_frac` of the motor's.

Why not a limited "play" hinge between motor and spring (MuJoCo's modelling-guide pattern): the node between
the two hinges then carries only armature, the limit is a soft constraint whose stiffness is about
m_eff / timeconst^2 (~1e5 N·m/rad for ~1 kg m^2 and 4 ms, against K_q ~ 2e6), and in our runs the gear node
crossed the band and penetrated the limit by 3x the band itself. The dead-zone spring has no light node: its
relative mode moves the motor's armature against K_q (sqrt(K/J) ~ 450 rad/s for joints 1-3).

The link angle (what the twin calls q_i) is motor + gear: a fixed tendon `<joint>_link_angle` (coefficients 1, 1)
carries the shipped joint's `frictionloss`, the twin's Coulomb friction against the link's own motion, which
the gear spring must carry (the link lags by tau_f / K_q, as in the twin). Contacts stay disabled: the sheet acts by the
force field, applied at the tool tip each step. Timestep 1 ms: the fastest mode, the wrist gear against
its link and the gear armature (~1.5e3 rad/s for joint 6), stays inside the explicit spring's stability
(omega dt < 2) and is damped implicitly; the arm's own modes on K_q are 10-40 Hz (25+ steps per period).
A declared bending tool (`twin.robot.tool_bending`) swings on its two flange hinges: damped at 5 % of critical on
its own mode (65 Hz for 8 kg on a Ø25 mm steel shank of 300 mm), a mode beyond ω·dt = 1 slowed by armature.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np

from twin.errors import ModelError
from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.plant_robots import plant_gear_stiffness
from twin.robot.description import load_robot
from twin.robot.facts import RobotDescription
from twin.robot.model import build_model, load_model
from twin.robot.tool import ToolSpec, apply_tool
from twin.robot.tool_bending import damp_bending

# MuJoCo's dry friction is a soft constraint: with the default impedance (d = 0.9) the light wrist slides at a
# fraction of the friction torque at the groove's 0.025 rad/s; d ~ 1 makes it a Coulomb friction there too.
FRICTION_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
FRICTION_SOLREF_STEPS = 2.0


@dataclass(frozen=True)
class Plant:
    """The compiled dynamic plant and the addresses the controller and sensors need.

    Attributes:
        model: Compiled model.
        robot: The robot it was built from.
        k_q: Gear stiffness K_q of the arm joints [N·m/rad], the plant's own (`plant_robots.py`) times the
            knobs' scales, shape (dof,).
        backlash_rad: Dead band of the arm joints [rad], shape (dof,).
        motor_qpos, motor_dof: qpos / dof addresses of the motor hinges, shape (dof,).
        link_qpos: qpos addresses of the gear hinges (the shipped joints), shape (dof,).
        link_dof: dof addresses of the gear hinges, shape (dof,).
        motor_armature: Armature of the motor hinges [kg m^2], shape (dof,).
        servo: Ids of the motor servos, shape (dof,).
        tcp_site, ft_site, tool_body, ft_sensor_adr: Ids, and the address of the F/T force sensor's data.
        tool_mass_kg: Mass below the F/T sensor [kg].
        p_base_sheet_origin: Sheet origin in the base (world) frame [m].
        stiffness_table: Name of the plant's K_q table (`plant:<robot>` or the assumption for another robot).
        stiffness_source: Where that table comes from, in words.
        tool: The declared tool the plant carries (`build_plant`); None: the robot model's own.
    """

    model: mujoco.MjModel
    robot: RobotDescription
    k_q: np.ndarray
    backlash_rad: np.ndarray
    motor_qpos: np.ndarray
    motor_dof: np.ndarray
    link_qpos: np.ndarray
    link_dof: np.ndarray
    motor_armature: np.ndarray
    servo: np.ndarray
    tcp_site: int
    ft_site: int
    tool_body: int
    ft_sensor_adr: int
    tool_mass_kg: float
    p_base_sheet_origin: np.ndarray
    stiffness_table: str = ""
    stiffness_source: str = ""
    tool: ToolSpec | None = None

    @property
    def dof(self) -> int:
        """Number of arm joints."""
        return self.robot.dof

    @property
    def dead_band_joints(self) -> np.ndarray:
        """Indices (0-based) of the joints with a dead band."""
        return np.flatnonzero(self.backlash_rad > 0.0)

    def link_angles(self, qpos: np.ndarray) -> np.ndarray:
        """Link angles q_i = motor + gear hinge [rad], shape (dof,)."""
        return qpos[self.motor_qpos] + qpos[self.link_qpos]

    def gear_torques(self, q_gear: np.ndarray, joints: np.ndarray) -> np.ndarray:
        """Dead-band spring torques -K dz(q_gear) of `joints` [N·m] for their gear angles `q_gear` [rad]."""
        half = self.backlash_rad[joints] / 2.0
        engaged = np.sign(q_gear) * np.maximum(np.abs(q_gear) - half, 0.0)
        return -self.k_q[joints] * engaged


def _shipped_parameters(
    spec: mujoco.MjSpec, robot: RobotDescription
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """K_q [N·m/rad], joint damping [N·m·s/rad], armature [kg m^2] and joint friction [N·m] of the shipped model
    (its K_q is the twin's prior: the plant uses it only for a robot it has no table for)."""
    model = spec.compile()
    arm = robot.addresses(model)
    k_q = model.actuator_gainprm[arm.actuator, 0].copy()
    dofs = arm.dof
    return (
        k_q,
        model.dof_damping[dofs].copy(),
        model.dof_armature[dofs].copy(),
        model.dof_frictionloss[dofs].copy(),
    )


class _Shipped(NamedTuple):
    """The shipped model's joint parameters, per arm joint."""

    k_q: np.ndarray  # gear stiffness K_q [N·m/rad]: the plant's own (`plant_robots.py`) times the knobs' scales
    damping: np.ndarray  # gear damping [N·m·s/rad]: the plant's K_q times the model's damping time
    armature: np.ndarray  # armature [kg m^2]
    friction: np.ndarray  # joint friction [N·m]


def build_plant(knobs: Knobs, robot: str | RobotDescription | None = None, tool: ToolSpec | None = None) -> Plant:
    """Build and compile the dynamic plant for these knobs.

    Args:
        knobs: Plant knobs (gear-stiffness scales, dead bands, friction, armature, timestep).
        robot: The robot; None: the default robot.
        tool: The tool on the cell's flange (a cell file's `[tool]`: length, mass, centre of gravity), in place of
            the model's own (`twin.robot.tool.apply_tool`): the cell's physical tool, so its tip, its gravity load
            and the sheet's lever arm are the tool's. None: the model's own tool.

    Raises:
        ModelError: The scene is missing, lacks the robot's joints or actuators, or does not compile.
    """
    robot = load_robot(robot)
    path = robot.model_path(scene=True)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        model_k_q, model_damping, armature, friction = _shipped_parameters(spec, robot)
        if tool is not None:
            apply_tool(spec, tool, flange_site=robot.flange_site, tool_site=robot.tool_site)
    except Exception as exc:
        raise ModelError(f"cannot build the dynamic plant from {path}: {exc}") from exc
    own = plant_gear_stiffness(robot, model_k_q)
    k_q = own.k_q * np.array(knobs.gear_stiffness_scales(robot.dof))
    # the gear's damping keeps the model's damping time (damping / K_q, 0.01 s in the shipped files) on the plant's K_q
    damping_time_s = np.divide(model_damping, model_k_q, out=np.zeros_like(model_damping), where=model_k_q > 0.0)
    shipped = _Shipped(k_q, damping_time_s * k_q, armature, friction)
    spec.option.timestep = knobs["timestep_s"]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    backlash = np.array(knobs.backlash_rad(robot.dof))
    for act in list(spec.actuators):
        spec.delete(act)
    for idx, name in enumerate(robot.joints):
        link = spec.joint(name)
        if link is None:
            raise ModelError(f"{path} has no joint {name}")
        _split_joint(spec, link, idx, shipped, knobs, backlash[idx])
    try:
        model = spec.compile()
    except Exception as exc:
        raise ModelError(f"cannot compile the dynamic plant from {path}: {exc}") from exc
    damp_bending(model, knobs["timestep_s"])  # a bending tool's hinges: 5 % of critical on its own mode

    def qadr(name: str) -> int:
        return int(model.jnt_qposadr[model.joint(name).id])
    tcp = model.site(robot.tool_site).id
    tool_body = int(model.site_bodyid[tcp])  # the tool: the sheet's force acts on it, the F/T sensor carries it
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    motors = [f"{name}_motor" for name in robot.joints]
    return Plant(
        model=model,
        robot=robot,
        k_q=shipped.k_q,
        backlash_rad=backlash,
        motor_qpos=np.array([qadr(name) for name in motors]),
        motor_dof=np.array([model.jnt_dofadr[model.joint(name).id] for name in motors]),
        link_qpos=np.array([qadr(name) for name in robot.joints]),
        link_dof=np.array([model.jnt_dofadr[model.joint(name).id] for name in robot.joints]),
        motor_armature=shipped.armature.copy(),
        servo=np.array([model.actuator(f"{name}_servo").id for name in robot.joints]),
        tcp_site=tcp,
        ft_site=model.site(robot.ft_site).id,
        tool_body=tool_body,
        ft_sensor_adr=int(model.sensor(robot.ft_force_sensor).adr[0]),
        tool_mass_kg=float(model.body_subtreemass[tool_body]),
        p_base_sheet_origin=(
            data.site(robot.sheet_site).xpos.copy() if robot.sheet_site is not None else data.site_xpos[tcp].copy()
        ),
        stiffness_table=own.table,
        stiffness_source=own.source,
        tool=tool,
    )


def controller_model(plant: Plant) -> mujoco.MjModel:
    """The controller's rigid model of the arm: the robot's model with the tool the controller is told (the
    plant's tool, rigid: its bending is the plant's), for the IK of the command and the gravity feed-forward."""
    if plant.tool is None:
        return load_model(scene=True, robot=plant.robot)
    return build_model(plant.robot, tool=plant.tool.rigid)


def _split_joint(
    spec: mujoco.MjSpec, link: mujoco.MjsJoint, idx: int, shipped: _Shipped, knobs: Knobs, backlash_rad: float
) -> None:
    """One arm joint as a motor hinge (servo-driven) and the shipped hinge as its gear, with the link friction on
    a tendon of both (module docstring)."""
    name = link.name
    motor = link.parent.add_joint()
    motor.name = f"{name}_motor"
    motor.type = mujoco.mjtJoint.mjJNT_HINGE
    motor.axis, motor.pos = link.axis, link.pos
    motor.armature = float(shipped.armature[idx])
    motor.damping = [knobs["viscous_friction_nms"], 0.0, 0.0]
    motor.frictionloss = knobs["coulomb_friction_nm"]
    motor.limited = mujoco.mjtLimited.mjLIMITED_FALSE
    # the gear spring: MuJoCo's own without a dead band, applied by the loop with one
    link.stiffness = [0.0 if backlash_rad > 0.0 else float(shipped.k_q[idx]), 0.0, 0.0]
    link.springref = 0.0
    link.damping = [float(shipped.damping[idx]), 0.0, 0.0]
    link.frictionloss = 0.0
    link.armature = float((knobs["gear_armature_frac"] * shipped.armature)[idx])
    link.limited = mujoco.mjtLimited.mjLIMITED_FALSE
    friction = (knobs["link_friction_scale"] * shipped.friction)[idx]
    if friction > 0.0:  # the shipped joint friction acts on the link's own motion: motor + gear
        link_angle = spec.add_tendon()
        link_angle.name = f"{name}_link_angle"
        link_angle.wrap_joint(motor.name, 1.0)
        link_angle.wrap_joint(link.name, 1.0)
        link_angle.frictionloss = float(friction)
        link_angle.solref_friction = [FRICTION_SOLREF_STEPS * knobs["timestep_s"], 1.0]
        link_angle.solimp_friction = list(FRICTION_SOLIMP)
    servo = spec.add_actuator()
    servo.name = f"{name}_servo"
    servo.target = motor.name
    servo.trntype = mujoco.mjtTrn.mjTRN_JOINT
    servo.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
