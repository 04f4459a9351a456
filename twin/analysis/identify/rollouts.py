"""Joint stiffness K_q, two routes (thesis sec. 4.1.2, Eqs. 4.4-4.5):

- from K_R through the Jacobian at the pose: the diagonal K_q with J K_q^-1 J^T ~ K_R^-1 (`fit_diagonal_kq`);
- directly from a run by rollouts: `scipy.optimize.least_squares` over twin replays of the run's command, the
  residual being the measured minus simulated tool tip (divided by the tracker noise), with the log-stiffness
  of the joints a groove run can see as unknowns (joints 2, 3 and 5 move the tool in x-z; joints 1, 4 and 6
  only in y or in rotation, where the run's forces have no component).

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
from twin.base.resources import robot_xml
from twin.errors import IdentificationError, InputError, ModelError
from twin.lab.effects import Effects, write_model_file
from twin.lab.measure import predict_tracker
from twin.process.forces import ForceHistory
from twin.robot.stiffness import set_joint_stiffness
from twin.runs.format import Run, run_placement
from twin.sim.quasi_static import Twin

RUN_OBSERVABLE_JOINTS = (1, 2, 4)  # 0-based: joints 2, 3, 5


@dataclass(frozen=True)
class KqRolloutFit:
    """K_q identified from a run by rollouts.

    Attributes:
        k_q_nm_per_rad: Joint stiffness [N·m/rad], shape (6,); joints not fitted keep the twin's value.
        fitted: Which joints were fitted, shape (6,) bool.
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
    """Route 1: the best diagonal K_q for a 3x3 K_R at the twin's `home` pose (joints 4, 6 default to the model's)."""
    k = np.asarray(k_r_n_per_m, dtype=float)
    if k.shape != (3, 3):
        raise InputError(f"K_R must be 3x3 [N/m] for the joint-stiffness fit, got {k.shape}")
    jac = twin.kinematics.jacobian(twin.kinematics.q_home)
    return fit_diagonal_kq(jac, k)


def kq_from_run(
    run: Run,
    *,
    history: ForceHistory | None = None,
    joints: tuple[int, ...] = RUN_OBSERVABLE_JOINTS,
    effects: Effects | None = None,
) -> KqRolloutFit:
    """Route 2: fit K_q of `joints` (0-based) to a run by least squares over twin replays.

    Raises:
        IdentificationError: The fit does not converge.
    """
    twin = Twin(history=history, effects=(effects or Effects()).robot, placement=run_placement(run.meta))
    start = twin.joint_stiffness.copy()
    noise = estimate_noise(run).position_m
    first = twin.simulate(run.commanded.t_s, run.commanded.values)
    q_ik = first.q_ik
    count = 0

    def residual(log_k: np.ndarray) -> np.ndarray:
        nonlocal count
        count += 1
        k = start.copy()
        k[list(joints)] = np.exp(log_k)
        set_joint_stiffness(twin.model, k)
        sim = twin.simulate(run.commanded.t_s, run.commanded.values, q_ik=q_ik)
        pred = predict_tracker(sim, run.tracker.t_s, effects or Effects())
        return ((run.tracker.values - pred)[:, [0, 2]] / noise).ravel()

    solution = least_squares(residual, np.log(start[list(joints)]), x_scale=1.0, diff_step=1e-3, max_nfev=60)
    if not solution.success:
        raise IdentificationError(f"K_q rollout fit did not converge: {solution.message}")
    k = start.copy()
    k[list(joints)] = np.exp(solution.x)
    set_joint_stiffness(twin.model, start)
    jtj = solution.jac.T @ solution.jac
    dof = max(solution.fun.size - len(joints), 1)
    sigma2 = float(solution.fun @ solution.fun) / dof
    std = np.full(6, np.nan)
    with contextlib.suppress(np.linalg.LinAlgError):  # singular: leave the uncertainty NaN
        std[list(joints)] = np.sqrt(np.diag(np.linalg.inv(jtj)) * sigma2)  # of log K = relative
    fitted = np.zeros(6, dtype=bool)
    fitted[list(joints)] = True
    rms = 1e3 * noise * float(np.sqrt(2.0 * np.mean(solution.fun**2)))  # norm of the x-z residual
    return KqRolloutFit(k, fitted, std, rms, count)


def write_joint_stiffness(path: str | Path, k_q_nm_per_rad: np.ndarray, *, note: str = "") -> Path:
    """Put K_q into the twin: `*.xml` writes the robot MJCF with the actuator gains set (MjSpec), anything
    else a twin model file (JSON) that `replay --model` and `compensate --model` read.
    """
    k = np.asarray(k_q_nm_per_rad, dtype=float)
    if k.shape != (6,) or not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise InputError(f"joint stiffness must be 6 finite positive values [N·m/rad], got {k!r}")
    path = Path(path)
    if path.suffix.lower() != ".xml":
        return write_model_file(path, Effects(), joint_stiffness_nm_per_rad=k, note=note)
    source = robot_xml()
    spec = mujoco.MjSpec.from_file(str(source))
    for i, value in enumerate(k, start=1):
        actuator = spec.actuator(f"actuator{i}")
        if actuator is None:
            raise ModelError(f"{source} has no actuator{i}")
        gain = np.array(actuator.gainprm)
        bias = np.array(actuator.biasprm)
        gain[0], bias[1] = value, -value
        actuator.gainprm, actuator.biasprm = gain, bias
    spec.meshdir = str((source.parent / spec.meshdir).resolve())  # the copy may live anywhere
    spec.compile()
    xml = spec.to_xml()
    return write_text(path, xml, protect=[source])
