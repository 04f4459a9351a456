"""The dynamic twin: the twin's own arm model stepped in time (MuJoCo forward dynamics) under a generic servo.

Where the quasi-static twin (`twin.sim.quasi_static`) solves each sample to rest, this mode integrates the same
MuJoCo model (`Twin.model`: its K_q as position actuators, its joint damping c, Coulomb `frictionloss`, lost-motion
and tool-bending hinges) with `mj_step` (implicitfast, 1 ms), so the arm moves while the force turns at corner
stops and pass reversals. The joint friction is MuJoCo's constraint made hard (solref 2h, solimp 0.999), so a
sliding joint carries its whole τ_f as the quasi-static twin's does.

**Servo (the generic form).** Each arm joint is a two-mass drive (Spong, Hutchinson & Vidyasagar, "Robot Modeling
and Control", 2nd ed. 2020, ch. 9, independent joint control of flexible joints): the motor, its rotor inertia J_m
(the model's `dof_armature`, moved to the motor side of the gear), drives the link through K_q and c, and a PID
loop closes on the motor angle θ, with derivative on the error, feed-forward and a pure delay d of the reference r:

    J_m θ̈ = K_p e + K_i ∫e dt + K_d ė + τ_ff − K_q (θ − q) − c (θ̇ − q̇),   e = r(t − d) − θ,
    τ_ff = K_q (r − q_0 − b (q_qs − q_0))(t − d) + a J r̈(t − d),

q_0 the unloaded link pose (K_q (r − q_0) is the arm's gravity, the set-points being taught under it), q_qs the
quasi-static twin's (its load), a the share of the inertial torque fed forward and b the share of the twin's own load. A
controller knows its own arm's gravity and inertia, not the sheet's force (b = 0): the sheet's load (and the joint
friction) reaches the loop as a disturbance, the motor gives way to it and the integral takes it up (Spong et al., ch.
9, the load torque as a disturbance of independent joint control), so the loop's rest state is still the quasi-static
twin's. Driven by a run's measured forces that is the loop that follows the arm (docs/dynamic-twin.md, "The arm under
the measured forces"); b = 1, the loop held on its reference while the twin's force turns, was this mode's first form,
and a fit on a run may take it where the twin's own sheet drives the arm. The gains are placed for the rigid joint (J =
J_m + the link's inertia at the first pose) at the poles (s + ω_s)(s² + 2ζω_s s + ω_s²) (Åström & Hägglund, "Advanced
PID Control", ISA 2006, ch. 6, pole placement): K_d = J(2ζ+1)ω_s, K_p = J(2ζ+1)ω_s², K_i = Jω_s³. For a rigid joint the
motor then follows

    θ/r = (a s³ + (2ζ+1)ω_s s² + (2ζ+1)ω_s² s + ω_s³) / ((s + ω_s)(s² + 2ζω_s s + ω_s²)) · e^(−sd),

each joint's bandwidth a share β of its first mode, ω_s = β sqrt(K_q / J) (the loop is set below the drive's
resonance, the usual design rule: G. Ellis, "Control System Design Guide", 4th ed. 2012, ch. 16). Five numbers
(β, ζ, d, a, b) are all it has, so they are learned from a run (`twin.analysis.learn.servo_fit`); its rest state is
the quasi-static one. The motor step is implicit Euler; β = inf puts the motor on r(t − d).

**Sheet (linearised contact).** The quasi-static replay at t − d gives the force f_qs, the tip p_qs and the sheet's
D = ∂f/∂p, recovered from its tip gain G = (I − C D)⁻¹ (`SimResult.tip_gain`, C = J K⁻¹ Jᵀ): D = C⁻¹(I − G⁻¹).
The moving arm feels f = f_qs + D (p − p_qs) at its tip; the formed surface is the quasi-static replay's. Given a
run's measured forces (`forces`), the arm is driven by them instead, with no sheet stiffness: the robot's part of a
run's gap with the arm moving, as `twin.analysis.learn.split` takes it with the arm at rest.

Cost: one quasi-static replay, then one `mj_step` per millisecond of the run (a fixed loop, arrays made before it;
the work around each step compiled, `twin.sim.compiled.drive`).
"""

from __future__ import annotations

import copy
import math
from dataclasses import replace
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.robot.model import lost_joint_name, lost_motion_schedule
from twin.sim.compiled.drive import contact_forces, motor_state, motor_step, pack_gains
from twin.sim.dynamic_servo import ServoModel
from twin.sim.gear_play import gear_play_references, rne_along
from twin.sim.result import SimResult

if TYPE_CHECKING:
    from twin.sim.quasi_static import Twin

#: MuJoCo timestep of the dynamic twin [s] (the arm's modes, 10-130 Hz, take 8+ steps a period).
TIMESTEP_S = 1e-3
#: ω h of the stiffest rotor mode sqrt(K_q / J_m) at most (an explicit step of an undamped spring is stable below
#: 2): the step is shortened below TIMESTEP_S where a learned gear is that stiff.
MOTOR_MODE_STEP = 1.5


def stiffness_diag(twin: Twin) -> np.ndarray:
    """The springs of every dof [N·m/rad]: K_q on the arm joints, the passive hinges' own elsewhere, (nv,)."""
    m = twin.model
    k = m.jnt_stiffness[m.dof_jntid].astype(float)
    k[twin.robot.addresses(m).dof] = twin.joint_stiffness
    if m.nq != m.nv or np.any(k <= 0):
        raise InputError(f"the twin's model has dofs {np.flatnonzero(k <= 0).tolist()} without a spring (nq {m.nq}, "
                         f"nv {m.nv}); the dynamic twin steps a chain of sprung hinges (arm, lost motion, tool)")
    return k


def sheet_stiffness(twin: Twin, sim: SimResult) -> np.ndarray:
    """The sheet's D = ∂f/∂p per sample from a quasi-static replay's tip gain, sheet frame [N/m], (n, 3, 3).

    Args:
        twin: The twin that made `sim` (its model and springs give C = J K⁻¹ Jᵀ).
        sim: Its quasi-static replay.
    """
    m = twin.model
    data, k_inv, jacp = mujoco.MjData(m), 1.0 / stiffness_diag(twin), np.zeros((3, m.nv))
    out, site = np.empty((len(sim.t_s), 3, 3)), m.site(twin.robot.tool_site).id
    for i, q in enumerate(sim.qpos):  # bounded: one Jacobian per sample
        data.qpos[:] = q
        mujoco.mj_kinematics(m, data)
        mujoco.mj_comPos(m, data)
        mujoco.mj_jacSite(m, data, jacp, None, site)
        j_sheet = twin.R_base_sheet.T @ jacp
        out[i] = np.linalg.solve((j_sheet * k_inv) @ j_sheet.T, np.eye(3) - np.linalg.inv(sim.tip_gain[i]))
    return out


def references(twin: Twin, sim: SimResult) -> np.ndarray:
    """The spring references of the replay, all dofs [rad], (n, nq): rigid IK, lost-motion schedule and gear play
    as the quasi-static twin takes them, plus K⁻¹ g of the unloaded pose (taught under gravity)."""
    m, robot, effects = twin.model, twin.robot, twin.effects
    q_nom = np.zeros((len(sim.t_s), m.nq))
    q_nom[:, robot.addresses(m).qpos] = sim.q_ik
    if effects.lost_motion_rad != 0:
        lost = [m.jnt_qposadr[m.joint(lost_joint_name(j)).id] for j in robot.lost_motion_joints]
        dx_dq = twin.R_base_sheet.T[0] @ twin.kinematics.jacobian(sim.q_ik[0])[:3]
        arm = [robot.joints.index(j) for j in robot.lost_motion_joints]
        q_nom[:, lost] = lost_motion_schedule(sim.p_cmd_sheet_m[:, 0], sim.direction, np.sign(dx_dq[arm]),
                                              effects.lost_motion_rad, effects.lost_motion_takeup_m)
    if effects.gear_play_rad:
        q_nom = gear_play_references(twin, q_nom, sim.t_s, sim.p_cmd_sheet_m, sim.direction, sim.qpos, sim.f_sheet_n)
    return q_nom + rne_along(m, sim.t_s, q_nom) / stiffness_diag(twin)


class DynamicTwin:
    """The dynamic twin of one commanded path, prepared once from its quasi-static replay (module docstring);
    `simulate(servo)` steps it under a servo (a fit calls it many times).

    Args:
        twin: The quasi-static twin (model, springs, friction); its `spec.servo` transient is not used.
        sim: Its quasi-static replay of the path, made without a servo transient (`Twin.simulate`).
        timestep_s: MuJoCo timestep [s].
        forces: (times [s] (k,), forces of the sheet on the tool, sheet frame [N] (k, 3)) to drive the arm by (a
            run's measured ones), with no sheet stiffness; None: the linearised sheet of `sim`.
    """

    def __init__(self, twin: Twin, sim: SimResult, timestep_s: float = TIMESTEP_S,
                 forces: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        if not (math.isfinite(timestep_s) and 1e-5 <= timestep_s <= 2e-3):
            raise InputError(f"timestep_s = {timestep_s!r}: expected [1e-5, 2e-3] s (the arm's modes are 10-130 Hz)")
        self.twin, self.sim = twin, sim
        m = self.model = copy.deepcopy(twin.model)
        arm = twin.robot.addresses(m)
        #: J_m per arm joint [kg·m²]: the model's rotor inertia, moved to the motor side of the gear.
        self.motor_inertia = np.maximum(m.dof_armature[arm.dof], 1e-3)
        # the gear spring on the rotor is stepped explicitly: a step short enough for its stiffest rotor mode
        fastest = float(np.max(np.sqrt(twin.joint_stiffness / self.motor_inertia)))
        timestep_s = min(timestep_s, MOTOR_MODE_STEP / fastest)
        if timestep_s < 1e-5:
            raise InputError(f"a gear of K_q {np.max(twin.joint_stiffness):.3g} N·m/rad on its rotor needs a step of "
                             f"{timestep_s:.2g} s: below the 1e-5 s the dynamic mode takes")
        m.opt.timestep, m.opt.integrator = timestep_s, mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        m.actuator_ctrllimited[:] = 0
        m.dof_solref[:, 0], m.dof_solimp[:, :2] = 2 * timestep_s, 0.999  # the hard friction constraint
        # the kernels' indices (`twin.sim.compiled.drive`), made once
        self._arm, self._act = np.asarray(arm.dof, dtype=np.int64), np.asarray(arm.actuator, dtype=np.int64)
        self._passive = np.setdiff1d(np.arange(m.nq), arm.qpos).astype(np.int64)
        m.dof_armature[arm.dof] = 0.0
        self.data, self.k_q, self._ref = mujoco.MjData(m), twin.joint_stiffness, references(twin, sim)
        self.forces = forces
        self.data.qpos[:] = sim.qpos[0]
        mujoco.mj_forward(m, self.data)
        full_m = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, self.data, full_m)
        #: J per arm joint, the rigid joint the gains are placed for [kg·m²]: motor plus link at the first pose.
        self.joint_inertia = self.motor_inertia + np.diag(full_m)[arm.dof]
        #: Each arm joint's first mode sqrt(K_q / J) [rad/s]: its servo's bandwidth is β times it.
        self.mode_rad_s = np.sqrt(self.k_q / self.joint_inertia)
        self._d_sheet = sheet_stiffness(twin, sim).reshape(len(sim.t_s), 9)
        self._tcp = m.site(twin.robot.tool_site).id
        #: The steps' times [s].
        self.t_steps = sim.t_s[0] + timestep_s * np.arange(int((sim.t_s[-1] - sim.t_s[0]) / timestep_s) + 1)

    def _at(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        """At times `t` (a step apart) of the quasi-static replay: references, their rate, the base-frame force,
        tip and sheet stiffness, and the arm joints' unloaded and loaded (quasi-static) poses."""
        sim, rot, h = self.sim, self.twin.R_base_sheet, self.model.opt.timestep
        t = np.clip(t, sim.t_s[0], sim.t_s[-1])
        ref = interp_rows(t, sim.t_s, self._ref)
        if self.forces is None:
            force, d_sheet = sim.force_at(t), interp_rows(t, sim.t_s, self._d_sheet).reshape(-1, 3, 3)
        else:
            force, d_sheet = interp_rows(t, *self.forces), np.zeros((len(t), 3, 3))
        return (ref, np.gradient(ref, h, axis=0), force @ rot.T,
                self.twin.p_base_sheet_origin + interp_rows(t, sim.t_s, sim.p_sheet_m) @ rot.T,
                np.einsum("ij,njk,lk->nil", rot, d_sheet, rot), interp_rows(t, sim.t_s, sim.q_ik),
                interp_rows(t, sim.t_s, sim.qpos[:, self._arm]))

    def simulate(self, servo: ServoModel) -> SimResult:
        """Step the arm along the path under `servo`.

        Args:
            servo: The joint servo.

        Returns:
            The quasi-static replay with `p_sheet_m`, `f_sheet_n` and `qpos` those of the moving arm, at the
            command's samples.

        Raises:
            InputError: The arm diverged (a servo, gear or friction too stiff for the timestep).
        """
        m, d, h, arm = self.model, self.data, self.model.opt.timestep, self._arm
        ref, rate, f_base, x_base, d_base, q_unloaded, q_static = self._at(self.t_steps - servo.delay_s)
        arm_ref, pas_ref = np.ascontiguousarray(ref[:, arm]), np.ascontiguousarray(ref[:, self._passive])
        arm_rate, jm, jt, k_q = np.ascontiguousarray(rate[:, arm]), self.motor_inertia, self.joint_inertia, self.k_q
        q_fed = q_unloaded + servo.load_feedforward * (q_static - q_unloaded)
        ff = k_q * (arm_ref - q_fed) + servo.feedforward * jt * np.gradient(arm_rate, h, axis=0)
        damping = m.dof_damping.copy()  # the gear's damper acts on the motor's speed less the link's
        c_arm, w, z, rigid = damping[arm], servo.bandwidth_over_mode * self.mode_rad_s, servo.damping_ratio, servo.rigid
        kd, kp, ki = jt * (2 * z + 1) * w, jt * (2 * z + 1) * w**2, jt * w**3
        gains = pack_gains(jm, kp, ki, kd, c_arm, k_q, h)
        mujoco.mj_resetData(m, d)
        d.qpos[:] = self.sim.qpos[0]
        # the arm starts at rest in the quasi-static pose: its integral holds the load there
        integral = np.zeros(len(arm)) if rigid else k_q * (q_fed[0] - self.sim.qpos[0, arm]) / ki
        state = motor_state(arm_ref[0], np.zeros(len(arm)), integral)
        n = len(self.t_steps)
        tips, qpos, force = np.empty((n, 3)), np.empty((n, m.nq)), np.empty((n, 3))
        jacp, drive = np.zeros((3, m.nv)), np.empty(m.nv)
        tip, tcp, jac_site = d.site_xpos[self._tcp], self._tcp, mujoco.mj_jacSite
        step1, step2 = mujoco.mj_step1, mujoco.mj_step2
        q, v, ctrl, qfrc, spring = d.qpos, d.qvel, d.ctrl, d.qfrc_applied, m.qpos_spring  # views of MuJoCo's memory
        for k in range(n):  # bounded: one step per timestep of the run
            motor_step(k, rigid, h, arm_ref, arm_rate, rate, ff, pas_ref, gains, state, arm, self._act,
                       self._passive, q, v, ctrl, spring, drive)
            step1(m, d)
            jac_site(m, d, jacp, None, tcp)
            contact_forces(k, tip, x_base, d_base, f_base, jacp, damping, drive, qfrc, q, tips, qpos, force)
            step2(m, d)
        return self._result(tips, qpos, force)

    def _result(self, tips: np.ndarray, qpos: np.ndarray, force: np.ndarray) -> SimResult:
        """The stepped arm at the command's samples, as a `SimResult`."""
        sim, rot, t = self.sim, self.twin.R_base_sheet, self.t_steps
        p_sheet = interp_rows(sim.t_s, t, tips - self.twin.p_base_sheet_origin) @ rot
        if not (np.all(np.isfinite(p_sheet)) and np.max(np.abs(p_sheet - sim.p_sheet_m)) < 0.05):
            raise InputError("the dynamic twin diverged (its tip more than 50 mm from the quasi-static one): its "
                             "servo, gears or joint friction are too stiff for its step")
        return replace(sim, p_sheet_m=p_sheet, f_sheet_n=interp_rows(sim.t_s, t, force) @ rot,
                       qpos=interp_rows(sim.t_s, t, qpos))


def without_servo(twin: Twin) -> Twin:
    """The twin without its servo transient (`spec.servo`, added after the quasi-static solve): the dynamic servo
    replaces it. The same twin where it has none."""
    return twin if twin.spec.servo is None else twin.spec.replace(servo=None).build()


def simulate_dynamic(
    twin: Twin, t_s: np.ndarray, p_cmd_sheet_m: np.ndarray, servo: ServoModel | None = None,
    timestep_s: float = TIMESTEP_S,
) -> SimResult:
    """Replay a commanded path on the dynamic twin: the quasi-static replay, then the arm stepped through it.

    Args:
        twin: The twin; one with a servo transient (`spec.servo`) is built again without it.
        t_s: Sample times [s], (n,), the command's stamps (its stops included).
        p_cmd_sheet_m: Commanded tool tip, sheet frame [m], (n, 3).
        servo: The joint servo; None: `ServoModel()`.
        timestep_s: MuJoCo timestep [s].

    Returns:
        The dynamic replay at the command's samples (`DynamicTwin.simulate`).
    """
    twin = without_servo(twin)
    sim = twin.simulate(t_s, p_cmd_sheet_m)
    return DynamicTwin(twin, sim, timestep_s).simulate(servo or ServoModel())
