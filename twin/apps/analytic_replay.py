"""The linear compliance replay d = J K_q^-1 J^T f(p_cmd + d): the physical floor of a compliant replay.

Used by `tx200-twin bench` (`twin.apps.bench`) as the yardstick of the twin's replay.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dgesv

from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.process.description import Process
from twin.process.fe.load import ForceHistory
from twin.process.force.base import ForceField
from twin.process.force.tool_friction import SheetModel, solve_sample
from twin.process.toolpath.groove import label_passes
from twin.runs.format import Run
from twin.sim.quasi_static import PASS_DEADBAND_M, Twin
from twin.sim.spec import TwinSpec

ANALYTIC_TOL_M = 1e-12  # fixed-point residual of the per-sample 3x3 Newton solve [m]
ANALYTIC_MAX_ITER = 20


@dataclass(frozen=True)
class AnalyticReplay:
    """A run replayed with the linear compliance model (no gravity, no MuJoCo in the loop).

    Attributes:
        p_sheet_m: Tool tip at equilibrium, sheet frame [m], shape (n, 3) at the commanded samples.
        f_sheet_n: Force of the sheet on the tool [N], shape (n, 3).
        tracker_pred_m: Tool tip at the run's tracker times [m], shape (m, 3).
        forces_pred_n: Force at the run's sensor times [N] (None when the run has none).
    """

    p_sheet_m: np.ndarray
    f_sheet_n: np.ndarray
    tracker_pred_m: np.ndarray
    forces_pred_n: np.ndarray | None


def _compliance_m_per_n(twin: Twin, p_cmd_sheet_m: np.ndarray) -> np.ndarray:
    """C = J_v K_q^-1 J_v^T at the IK of each commanded sample [m/N], shape (n, 3, 3)."""
    kin = twin.kinematics
    q_ik = kin.ik_path(p_cmd_sheet_m + twin.p_base_sheet_origin)
    J_v = kin.jacobians(q_ik)[:, :3]
    return (J_v / twin.joint_stiffness) @ J_v.transpose(0, 2, 1)  # (n, 3, 3) [m/N]


def _solve_samples(
    field: ForceField, p_cmd_sheet_m: np.ndarray, compliance: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Solve d = C f(p_cmd + d) sample by sample, advancing the field's formed surface after each.

    Args:
        field: The twin's sheet field with the tool's sliding friction (`Twin.field`); reset here.
        p_cmd_sheet_m: Commanded tool tip, sheet frame [m], shape (n, 3).
        compliance: Compliance at each sample [m/N], shape (n, 3, 3).

    Returns:
        Tool tip at equilibrium [m] and force of the sheet on the tool [N], each shape (n, 3).

    Raises:
        InputError: A sample's Newton iteration did not converge.
    """
    p_cmd = p_cmd_sheet_m
    pass_index, direction = label_passes(p_cmd[:, 0], deadband_m=PASS_DEADBAND_M)
    passes, dirs = [int(v) for v in pass_index], [int(v) for v in direction]
    field.reset()
    n = len(p_cmd)
    p_out, f_out = np.empty((n, 3)), np.empty((n, 3))
    eye = np.eye(3)
    d = np.zeros(3)
    for i in range(n):
        c, pi, di, p_i = compliance[i], passes[i], dirs[i], p_cmd[i]

        def deflection(
            sheet: SheetModel, d0: np.ndarray = d, c: np.ndarray = c, p_i: np.ndarray = p_i, i: int = i
        ) -> np.ndarray:
            """d = C f(p_i + d) by a 3x3 Newton iteration from d0 [m]."""
            d = d0
            for _ in range(ANALYTIC_MAX_ITER):
                f, s = sheet(p_i + d)
                r = d - c @ f
                if abs(r).max() < ANALYTIC_TOL_M:
                    return d
                d = d - dgesv(eye - c @ s, r)[2]
            raise InputError(f"analytic replay: sample {i} did not converge (residual {abs(r).max():.3g} m)")

        # the tool's sliding friction is solved one regime at a time, as in the twin (process.tool_friction)
        def tip(d_eq: np.ndarray, p_i: np.ndarray = p_i) -> np.ndarray:
            return p_i + d_eq

        d = solve_sample(field, pi, di, deflection, tip)
        p = p_cmd[i] + d
        f_out[i] = field.force(p, pi, di)
        field.advance(p, pi)
        p_out[i] = p
    return p_out, f_out


def analytic_replay(run: Run, *, twin: Twin | None = None, history: ForceHistory | None = None) -> AnalyticReplay:
    """Replay a run with d = J K_q^-1 J^T f per sample, the field evaluated at the deflected tool tip.

    The per-sample Jacobian comes from the IK of the commanded path (the twin's kinematics), the compliance
    C = J_v K_q^-1 J_v^T is formed for all samples at once, and each sample solves d = C f(p_cmd + d) by a
    3x3 Newton iteration (the sheet is stiffer than the robot, so a plain fixed point would diverge) before
    the field's formed surface advances, exactly as in the twin. Gravity is taught away as in the twin.

    Args:
        run: A measured run (only its commanded path and stream times are used).
        twin: A ready twin whose kinematics, K_q and field are used; default a fresh nominal one.
        history: Force history for a fresh twin.

    Returns:
        The linear-model prediction.

    Raises:
        InputError: The per-sample solve did not converge.
    """
    twin = twin or TwinSpec(process=Process(history=history)).build()
    t_s, p_cmd = run.commanded.t_s, run.commanded.values
    compliance = _compliance_m_per_n(twin, p_cmd)
    p_out, f_out = _solve_samples(twin.field, p_cmd, compliance)
    tracker = interp_rows(run.tracker.t_s, t_s, p_out)
    forces = interp_rows(run.forces.t_s, t_s, f_out) if run.forces is not None else None
    return AnalyticReplay(p_out, f_out, tracker, forces)
