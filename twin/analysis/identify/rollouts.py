"""Joint stiffness K_q, two routes (thesis sec. 4.1.2, Eqs. 4.4-4.5):

- from K_R through the Jacobian at the pose: the diagonal K_q with J K_q^-1 J^T ~ K_R^-1 (`fit_diagonal_kq`);
- directly from a run by rollouts: `scipy.optimize.least_squares` over twin replays of the run's command, the
  residual being the measured minus simulated tool tip (divided by the tracker noise), with the log-stiffness
  of the joints a run in the x-z plane can see as unknowns (`observable_joints`: those that move the tool in
  x-z at the run's start; on the TX200's groove joints 2, 3 and 5, while joints 1, 4 and 6 move it only in y or
  in rotation, where the run's forces have no component).

`write_joint_stiffness` puts a K_q into the twin: as a twin model file (JSON) or as an MJCF (via MjSpec).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from scipy.optimize import least_squares

from twin.analysis.discrepancy.residuals import estimate_noise
from twin.analysis.identify.joint import KqFit, fit_diagonal_kq
from twin.base.csvio import write_text
from twin.errors import IdentificationError, InputError, ModelError
from twin.robot.kinematics import Kinematics
from twin.runs.format import Run, run_placement
from twin.sim.measure import predict_tracker
from twin.sim.model_file import write_model_file
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

#: A joint counts as observable from x-z tool motion when its x-z Jacobian column is at least this fraction of
#: the largest one [-].
OBSERVABLE_SHARE = 0.05


@dataclass(frozen=True)
class KqRolloutFit:
    """K_q identified from a run by rollouts.

    Attributes:
        k_q_nm_per_rad: Joint stiffness [N·m/rad], shape (dof,); joints not fitted keep the twin's value.
        fitted: Which joints were fitted, shape (dof,) bool.
        relative_std: One-sigma relative uncertainty of each fitted stiffness (from the Gauss-Newton
            covariance), NaN for joints not fitted.
        residual_rms_mm: Tool-tip residual after the fit [mm].
        evaluations: Number of twin replays.
    """

    k_q_nm_per_rad: np.ndarray
    fitted: np.ndarray
    relative_std: np.ndarray
    residual_rms_mm: float
    evaluations: int


def kq_from_stiffness(twin: Twin, k_r_n_per_m: np.ndarray) -> KqFit:
    """Route 1: the best diagonal K_q for a 3x3 K_R at the twin's `home` pose (joints 4, 6 default to the model's).
    A declared tool's own bending (`twin.robot.tool_bending`) is in the measured K_R: its compliance is taken out
    first, so the joints are not made softer for the tool's bending."""
    from twin.robot.tool_bending import bending_compliance_at

    k = np.asarray(k_r_n_per_m, dtype=float)
    if k.shape != (3, 3):
        raise InputError(f"K_R must be 3x3 [N/m] for the joint-stiffness fit, got {k.shape}")
    q_home = twin.kinematics.q_home
    c_tool = bending_compliance_at(twin.model, twin.robot, q_home)
    if np.any(c_tool):
        c_arm = np.linalg.inv(k) - c_tool
        if np.min(np.linalg.eigvalsh(0.5 * (c_arm + c_arm.T))) <= 0.0:
            raise InputError("the measured compliance is smaller than the declared tool's own bending alone: the "
                             "tool's bending stiffness (the cell's [tool]) is too low for these load cases")
        k = np.linalg.inv(c_arm)
    return fit_diagonal_kq(twin.kinematics.jacobian(q_home), k)


def observable_joints(kinematics: Kinematics, q: np.ndarray, R_base_sheet: np.ndarray) -> tuple[int, ...]:
    """The joints (0-based) that move the tool tip in the sheet's x-z plane at `q` (`OBSERVABLE_SHARE`).

    Args:
        kinematics: The robot's kinematics.
        q: Pose [rad], shape (dof,).
        R_base_sheet: Orientation of the sheet frame in the base (3, 3).
    """
    jac = (R_base_sheet.T @ kinematics.jacobian(q)[:3])[[0, 2]]
    size = np.linalg.norm(jac, axis=0)
    return tuple(int(j) for j in np.flatnonzero(size >= OBSERVABLE_SHARE * size.max()))


def kq_from_run(run: Run, spec: TwinSpec | None = None, *, joints: tuple[int, ...] | None = None) -> KqRolloutFit:
    """Route 2: fit K_q of `joints` (0-based) to a run by least squares over twin replays.

    Args:
        run: A measured run (its placement is the twin's).
        spec: The twin (robot, process, the effects it knows); None: the default cell.
        joints: Joints to fit; None: those the run can see (`observable_joints` at its first sample).

    Raises:
        IdentificationError: The fit does not converge.
    """
    twin = (spec or TwinSpec()).replace(placement=run_placement(run.meta)).build()
    effects = twin.effects
    start = twin.joint_stiffness.copy()
    noise = estimate_noise(run).position_m
    first = twin.simulate(run.commanded.t_s, run.commanded.values)
    q_ik = first.q_ik
    if joints is None:
        joints = observable_joints(twin.kinematics, q_ik[0], twin.R_base_sheet)
    count = 0

    def residual(log_k: np.ndarray) -> np.ndarray:
        nonlocal count
        count += 1
        k = start.copy()
        k[list(joints)] = np.exp(log_k)
        twin.set_joint_stiffness(k)
        sim = twin.simulate(run.commanded.t_s, run.commanded.values, q_ik=q_ik)
        pred = predict_tracker(sim, run.tracker.t_s, effects)
        return ((run.tracker.values - pred)[:, [0, 2]] / noise).ravel()

    solution = least_squares(residual, np.log(start[list(joints)]), x_scale=1.0, diff_step=1e-3, max_nfev=60)
    if not solution.success:
        raise IdentificationError(f"K_q rollout fit did not converge: {solution.message}")
    k = start.copy()
    k[list(joints)] = np.exp(solution.x)
    twin.set_joint_stiffness(start)
    jtj = solution.jac.T @ solution.jac
    dof = max(solution.fun.size - len(joints), 1)
    sigma2 = float(solution.fun @ solution.fun) / dof
    std = np.full(twin.robot.dof, np.nan)
    with contextlib.suppress(np.linalg.LinAlgError):  # singular: leave the uncertainty NaN
        std[list(joints)] = np.sqrt(np.diag(np.linalg.inv(jtj)) * sigma2)  # of log K = relative
    fitted = np.zeros(twin.robot.dof, dtype=bool)
    fitted[list(joints)] = True
    rms = 1e3 * noise * float(np.sqrt(2.0 * np.mean(solution.fun**2)))  # norm of the x-z residual
    return KqRolloutFit(k, fitted, std, rms, count)


def write_joint_stiffness(
    path: str | Path, k_q_nm_per_rad: np.ndarray, *, note: str = "", spec: TwinSpec | None = None
) -> Path:
    """Put K_q into the twin: `*.xml` writes the robot MJCF with the actuator gains set (MjSpec), anything
    else a twin model file (JSON) that `replay --model` and `compensate --model` read.

    Args:
        path: The output file.
        k_q_nm_per_rad: K_q per arm joint [N·m/rad].
        note: A note for the model file.
        spec: The twin the stiffness belongs to (its robot, process and placement go into the model file);
            None: the default cell.
    """
    spec = spec or TwinSpec()
    robot = spec.robot
    k = robot.joint_vector(k_q_nm_per_rad, "joint stiffness", "N·m/rad", positive=True)
    path = Path(path)
    if path.suffix.lower() != ".xml":
        return write_model_file(path, spec.replace(joint_stiffness_nm_per_rad=tuple(k)), note=note)
    source = robot.mjcf
    model_spec = mujoco.MjSpec.from_file(str(source))
    for name, value in zip(robot.actuators, k, strict=True):
        actuator = model_spec.actuator(name)
        if actuator is None:
            raise ModelError(f"{source} has no actuator {name}")
        gain = np.array(actuator.gainprm)
        bias = np.array(actuator.biasprm)
        gain[0], bias[1] = value, -value
        actuator.gainprm, actuator.biasprm = gain, bias
    model_spec.meshdir = str((source.parent / model_spec.meshdir).resolve())  # the copy may live anywhere
    model_spec.compile()
    xml = model_spec.to_xml()
    return write_text(path, xml, protect=[source])
