"""The twin: the compliant MuJoCo robot driven along a commanded path against the sheet force field.

Per sample the robot is solved to quasi-static equilibrium (qvel = qacc = 0) under its joint springs,
gravity, joint friction and the force the sheet exerts on the tool, from the stateful field
(`twin.sim.equilibrium`). The loop over the samples runs compiled (`twin.sim.compiled`) where the model is a chain
of hinges and the force model declares a compiled kernel, else in Python (`twin.sim.python_loop`); both give the
same equilibria.

The path is taught under gravity: the set-points are q_ref = q_ik + K^-1 g(q_ik), so the unloaded robot
lands exactly on the IK solution, and deflection = loaded - unloaded. After each sample the field's formed
surface advances to where the tool really was. A gear's play (`Effects.gear_play_rad`) replays twice: the second
time each gear rests on the flank the first replay's torques set (`twin.sim.gear_play`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from twin.errors import InputError
from twin.process.force.base import ForceField
from twin.process.force.registry import build_force_field
from twin.process.force.tool_friction import SlidingFriction
from twin.process.toolpath.groove import label_passes
from twin.robot.kinematics import Kinematics
from twin.robot.model import build_model, lost_joint_name, lost_motion_schedule
from twin.robot.stiffness import joint_stiffness, set_joint_stiffness
from twin.robot.tool_bending import bending_dofs
from twin.sim.compiled import compiled_replay
from twin.sim.compiled.work import tip_gains
from twin.sim.equilibrium import EquilibriumSolver
from twin.sim.ft_sensor import flange_sensor_forces
from twin.sim.gear_play import gear_play_references
from twin.sim.giving_frame import with_frame
from twin.sim.python_loop import python_loop
from twin.sim.result import LoopOutput, SimResult

if TYPE_CHECKING:  # a spec builds its twin (`TwinSpec.build`); the twin only reads the spec it is given
    from twin.sim.spec import TwinSpec

# Back-travel that declares a reversal of the commanded path [m]: a compensated command may step back a
# fraction of a millimetre where the force ramps up, a real reversal travels a whole stroke (>= 61 mm).
PASS_DEADBAND_M = 2e-3
#: Commanded paths whose rigid IK the twin keeps.
IK_MEMO_PATHS = 4


class Twin:
    """Quasi-static compliant-robot twin of the forming cell, built from a `TwinSpec` (`TwinSpec.build()`).

    The robot model carries the spec's declared tool (`twin.robot.tool`) and robot-side effects
    (`twin.robot.model.build_model`); the controller's kinematics (IK) use the nominal robot with that tool. The
    force field is the process's force model (`twin.process.force.registry`) fitted to the FE history, scaled by the
    `force_scale` effect (not the sheet's penetration sensitivity), on a frame that gives (`twin.sim.giving_frame`)
    and, where its in-plane force flips with the command, in the tool's sliding friction. Sheet frame throughout.

    Args:
        spec: The twin's specification (`TwinSpec()`: the default cell).
    """

    #: Run the per-sample loop compiled (`twin.sim.compiled`) where the model and field allow it; False: the
    #: Python loop, MuJoCo called per Newton iteration (the reference the compiled loop is tested against).
    use_compiled_loop: bool = True

    def __init__(self, spec: TwinSpec) -> None:
        self.spec = spec
        self.robot, self.effects, self.placement = spec.robot, spec.effects, spec.placement
        self.history = spec.process.force_history()
        effects = self.effects
        self.model = build_model(self.robot, tool_offset_m=effects.tool_offset_m,
                                 lost_motion=effects.lost_motion_rad != 0, tool=spec.tool)
        # the controller's kinematics (IK) use the nominal robot with the declared tool, rigid (its bending hinges,
        # `twin.robot.tool_bending`, are the tool's deflection); a separate model only when effects change it
        bends = spec.tool is not None and spec.tool.bending_stiffness_n_per_m is not None
        nominal = build_model(self.robot, tool=None if spec.tool is None else spec.tool.rigid) \
            if effects.changes_model or bends else self.model
        if spec.joint_stiffness is not None:
            set_joint_stiffness(self.model, spec.joint_stiffness, self.robot)
            if nominal is not self.model:
                set_joint_stiffness(nominal, spec.joint_stiffness, self.robot)
        self.kinematics = Kinematics(nominal, robot=self.robot)
        self.data = mujoco.MjData(self.model)
        axes = effects.force_scale * np.array([effects.get("force_scale_in_plane")] * 2 + [1.0])
        scaled = self.history if np.all(axes == 1.0) else replace(self.history, f_sheet_n=self.history.f_sheet_n * axes)
        self._reversal_m = spec.process.friction_reversal_m
        self.set_sheet_field(build_force_field(spec.process, scaled))
        m = self.model
        self._tcp = m.site(self.robot.tool_site).id
        arm = self.robot.addresses(m)
        self._arm_dof, self._arm_qpos = arm.dof, arm.qpos
        lost = [lost_joint_name(j) for j in self.robot.lost_motion_joints] if effects.lost_motion_rad != 0 else []
        self._lost_dof = np.array([m.jnt_dofadr[m.joint(name).id] for name in lost], dtype=int)
        self._lost_qpos = np.array([m.jnt_qposadr[m.joint(name).id] for name in lost], dtype=int)
        #: The passive springs beside the arm joints' K_q: the lost-motion hinges and the tool's bending hinges.
        self._passive_dof = np.concatenate([self._lost_dof, bending_dofs(m)])
        #: Column of each lost-motion joint among the arm joints.
        self._lost_arm = [self.robot.joints.index(j) for j in self.robot.lost_motion_joints]
        self.p_base_sheet_origin = self.placement.origin_in(self.kinematics)
        #: Orientation of the sheet frame in the base frame (the placement's yaw).
        self.R_base_sheet = self.placement.R_base_sheet
        self._solver = EquilibriumSolver(m, self.data, self._tcp, self.p_base_sheet_origin, self.R_base_sheet)
        self._ik_memo: list[tuple[np.ndarray, np.ndarray]] = []
        #: Whether the last `simulate` ran the compiled loop (else the Python one).
        self.last_loop_compiled = False
        if spec.joint_friction is not None:
            self.joint_friction = spec.joint_friction

    def set_sheet_field(self, field: ForceField) -> None:
        """Press the tool against `field` from now on, on the clamping frame the effects give
        (`twin.sim.giving_frame`), with the tool's sliding friction around it where the model's in-plane force
        flips with the command (`ForceField.tangential_from_command`).
        """
        framed = with_frame(field, self.effects)
        wrap = field.tangential_from_command and self._reversal_m is not None
        self.field: ForceField = SlidingFriction(framed, self._reversal_m) if wrap else framed  # type: ignore[arg-type]
        self._sheet = field

    @property
    def sheet_field(self) -> ForceField:
        """The sheet's force field itself (`field` without the frame and the tool's sliding friction around it)."""
        return self._sheet

    @property
    def joint_friction(self) -> np.ndarray:
        """Coulomb friction of the arm joints [N·m]: the model's `frictionloss` (0 where none is given)."""
        return self.model.dof_frictionloss[self._arm_dof].copy()

    @joint_friction.setter
    def joint_friction(self, tau_nm: np.ndarray) -> None:
        tau = self.robot.joint_vector(tau_nm, "joint friction", "N·m", nonnegative=True)
        self.model.dof_frictionloss[self._arm_dof] = tau

    @property
    def joint_stiffness(self) -> np.ndarray:
        """K_q of the arm joints [N·m/rad]."""
        return joint_stiffness(self.model, self.robot)

    def set_joint_stiffness(self, k_q_nm_per_rad: np.ndarray) -> None:
        """Set K_q of the arm joints [N·m/rad] in place (a calibration or a sweep's draw)."""
        set_joint_stiffness(self.model, k_q_nm_per_rad, self.robot)

    def _stiffness_diag(self) -> np.ndarray:
        k = np.zeros(self.model.nv)
        k[self._arm_dof] = self.joint_stiffness
        if self._passive_dof.size:
            k[self._passive_dof] = self.model.jnt_stiffness[self.model.dof_jntid[self._passive_dof]]
        return k

    def _gravity(self, qpos: np.ndarray) -> np.ndarray:
        m, d = self.model, self.data
        d.qpos[:] = qpos
        d.qvel[:] = 0.0
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        out = np.zeros(m.nv)
        mujoco.mj_rne(m, d, 0, out)
        return out

    def _gravity_gradient(self, qpos: np.ndarray, step: float = 1e-6) -> np.ndarray:
        grad = np.zeros((self.model.nv, self.model.nv))
        for j in range(self.model.nv):
            dq = np.zeros(self.model.nq)
            dq[j] = step
            grad[:, j] = (self._gravity(qpos + dq) - self._gravity(qpos - dq)) / (2 * step)
        return grad

    def _ik_path(self, p_cmd: np.ndarray) -> np.ndarray:
        """Rigid IK of a commanded path [rad], (n, dof); the last few paths' solutions are kept (a replay, a
        discrepancy search or a sweep drives one command many times, and the IK depends on the command only)."""
        for p_known, q_known in self._ik_memo:
            if p_known.shape == p_cmd.shape and np.array_equal(p_known, p_cmd):
                return q_known.copy()
        q_ik = self.kinematics.ik_path(self.p_base_sheet_origin + p_cmd @ self.R_base_sheet.T)
        self._ik_memo = [(p_cmd.copy(), q_ik.copy()), *self._ik_memo[: IK_MEMO_PATHS - 1]]
        return q_ik

    def ik_path(self, p_cmd_sheet_m: np.ndarray) -> np.ndarray:
        """The rigid IK of a commanded path in the sheet frame [rad], (n, dof) (the last few paths' kept)."""
        return self._ik_path(np.asarray(p_cmd_sheet_m, dtype=float))

    def _full_qpos(self, q_arm: np.ndarray) -> np.ndarray:
        qpos = np.zeros(self.model.nq)
        qpos[self._arm_qpos] = q_arm
        return qpos

    def simulate(
        self, t_s: np.ndarray, p_cmd_sheet_m: np.ndarray, *, q_ik: np.ndarray | None = None
    ) -> SimResult:
        """Drive the twin along a commanded tool-tip path and solve every sample to equilibrium.

        Args:
            t_s: Sample times [s], shape (n,), strictly increasing.
            p_cmd_sheet_m: Commanded tool tip in the sheet frame [m], shape (n, 3).
            q_ik: Rigid IK solution of this same path [rad], shape (n, dof), from an earlier `SimResult.q_ik`
                (saves the IK when one command is replayed many times); computed when None.

        Returns:
            The simulated run at the commanded samples.

        Raises:
            InputError: Bad shapes or non-finite values.
            UnreachableError, SingularityError: From inverse kinematics of the commanded path.
        """
        t_s = np.asarray(t_s, dtype=float)
        p_cmd = np.asarray(p_cmd_sheet_m, dtype=float)
        if p_cmd.ndim != 2 or p_cmd.shape[1] != 3 or len(t_s) != len(p_cmd) or len(t_s) < 2:
            raise InputError(
                f"expected t_s (n,) and p_cmd_sheet_m (n, 3) with n >= 2, got {t_s.shape}, {p_cmd.shape}"
            )
        if not (np.all(np.isfinite(p_cmd)) and np.all(np.isfinite(t_s))):
            raise InputError("commanded path holds NaN or inf")
        m = self.model
        if q_ik is None:
            q_ik = self._ik_path(p_cmd)
        elif q_ik.shape != (len(t_s), self.robot.dof):
            raise InputError(f"q_ik has shape {q_ik.shape}, expected {(len(t_s), self.robot.dof)}")
        pass_index, direction = label_passes(p_cmd[:, 0], deadband_m=PASS_DEADBAND_M)
        k_diag = self._stiffness_diag()
        grad_g = self._gravity_gradient(self._full_qpos(q_ik[0]))
        q_nominal_all = np.zeros((len(t_s), m.nq))
        q_nominal_all[:, self._arm_qpos] = q_ik
        q_nominal_all[:, self._lost_qpos] = self._lost_motion_references(p_cmd, direction, q_ik)
        h_const = np.diag(k_diag) + grad_g  # the Newton matrix without the sheet term
        out = self._loop(q_nominal_all, pass_index, direction, k_diag, h_const)
        if self.effects.gear_play_rad:  # again, each gear on the flank the first replay's torques set
            q_nominal_all = gear_play_references(self, q_nominal_all, t_s, p_cmd, direction, out.qpos, out.f_sheet_n)
            out = self._loop(q_nominal_all, pass_index, direction, k_diag, h_const)
        tip_gain = np.empty((len(t_s), 3, 3))  # (I - J K⁻¹ Jᵀ S)⁻¹ per sample
        if not tip_gains(out.jac, np.ascontiguousarray(k_diag, dtype=float), out.stiffness, tip_gain):
            raise np.linalg.LinAlgError("singular tool-tip gain I - J K⁻¹ Jᵀ S")
        formed_x, formed_z = self.field.x_grid_m, self.field.formed_z_m
        p_sheet = out.p_sheet_m
        if self.spec.servo is not None:  # the servo's transient, after the quasi-static solve (`twin.sim.servo`)
            J = self.kinematics.jacobians(q_ik)[:, :3, :]
            J_sheet = np.einsum("ki,nkj->nij", self.R_base_sheet, J)
            p_sheet = p_sheet + self.spec.servo.deflection_m(t_s, out.f_sheet_n, J_sheet)
        return SimResult(
            t_s=t_s,
            p_cmd_sheet_m=p_cmd,
            p_unloaded_sheet_m=out.p_unloaded_sheet_m,
            p_sheet_m=p_sheet,
            f_sheet_n=out.f_sheet_n,
            qpos=out.qpos,
            q_ik=q_ik,
            pass_index=pass_index,
            direction=direction,
            formed_x_m=np.asarray(formed_x, dtype=float).copy(),
            formed_z_m=np.asarray(formed_z, dtype=float).copy(),
            iterations=out.iterations,
            tip_gain=tip_gain,
            force_steps=self.sheet_field.steps_between_passes,
        )

    def _loop(
        self, q_nominal_all: np.ndarray, pass_index: np.ndarray, direction: np.ndarray, k_diag: np.ndarray,
        h_const: np.ndarray,
    ) -> LoopOutput:
        """Every sample to equilibrium from a fresh field: the compiled loop where it applies, else Python's."""
        self.field.reset()
        out = None
        if self.use_compiled_loop:
            out = compiled_replay(
                self.model, self._tcp, self.field, q_nominal_all, pass_index, direction, self.p_base_sheet_origin,
                k_diag, h_const, self._solver.predict_active_set, self.data, self.R_base_sheet,
            )
        self.last_loop_compiled = out is not None
        if out is None:
            out = python_loop(
                self.model, self.data, self._tcp, self.field, self._solver,
                q_nominal_all, pass_index, direction, k_diag, h_const,
            )
        return out

    def _lost_motion_references(self, p_cmd: np.ndarray, direction: np.ndarray, q_ik: np.ndarray) -> np.ndarray:
        """Spring references of the lost-motion hinges along the command [rad], shape (n, hinges)."""
        if not self._lost_dof.size:
            return np.zeros((len(p_cmd), 0))
        dx_dq = self.R_base_sheet.T[0] @ self.kinematics.jacobian(q_ik[0])[:3]  # sheet x per joint angle
        return lost_motion_schedule(
            p_cmd[:, 0], direction, np.sign(dx_dq[self._lost_arm]), self.effects.lost_motion_rad,
            self.effects.lost_motion_takeup_m,
        )

    def sensor_forces(self, result: SimResult, t_s: np.ndarray) -> np.ndarray:
        """Read MuJoCo's flange force sensor at the given times, as the run format wants it.

        The force is applied at the tool tip and the robot's MuJoCo force sensor read at equilibrium, tared by an
        unloaded reading at the same pose (`twin.sim.ft_sensor.flange_sensor_forces`). With the per-pass table
        field the force steps at each reversal and is not interpolated across it.

        Args:
            result: A run from `simulate`.
            t_s: Sensor sample times [s], within the run.

        Returns:
            Force exerted by the sheet on the tool, sheet frame [N], shape (m, 3).
        """
        return flange_sensor_forces(self.model, self.data, result, t_s, robot=self.robot,
                                    R_base_sheet=self.R_base_sheet)

    def static_deflection(self, f_base_n: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Equilibrium tool-tip deflection under a constant force at the tool tip (no sheet field).

        The load is applied to the robot at rest, unloaded (a load test: weights hung on the tool, thesis
        §4.2.1), so each joint's friction takes the first τ_f of its torque change (stick/slip).

        Args:
            f_base_n: Force on the tool tip, base frame [N], shape (3,).
            q: Pose (rigid IK angles of the arm joints) [rad]; default `home`.

        Returns:
            Loaded minus unloaded tool-tip position [m], shape (3,).
        """
        m, d = self.model, self.data
        f = np.asarray(f_base_n, dtype=float)
        q_nominal = self._full_qpos(self.kinematics.q_home if q is None else np.asarray(q, dtype=float))
        k_diag = self._stiffness_diag()
        g_nom = self._gravity(q_nominal)
        p0 = d.site_xpos[self._tcp].copy()
        q_ref = q_nominal + g_nom / k_diag
        h_const = np.diag(k_diag) + self._gravity_gradient(q_nominal)
        no_sheet = np.zeros((3, 3))
        q, _, _, _ = self._solver.solve(q_nominal.copy(), q_ref, k_diag, h_const, lambda _p: (f, no_sheet),
                                        q_ref - q_nominal)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        return d.site_xpos[self._tcp] - p0
