"""The twin's per-sample loop in Python: MuJoCo asked at every Newton iteration, any field, any model.

The reference of the compiled loop (`twin.sim.compiled`), and the loop for what that one does not express
(a force model without a compiled kernel; a robot model that is not a chain of hinges). Per sample: the unloaded pose's gravity (`mj_rne`), the set-points q_ref = q_ik + K⁻¹ g, the start point
extrapolated from the pass's last two deflections, the equilibrium by regimes of the tool's sliding friction
(`twin.process.force.tool_friction.solve_sample`) with joint friction (`twin.sim.equilibrium`), then the force at the
equilibrium and the field's advance.
"""

from __future__ import annotations

import mujoco
import numpy as np

from twin.process.force.base import ForceField
from twin.process.force.tool_friction import SheetModel, SlidingFriction, solve_sample
from twin.sim.equilibrium import EquilibriumSolver
from twin.sim.result import LoopOutput


def python_loop(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    tcp_site: int,
    field: ForceField,
    solver: EquilibriumSolver,
    q_nominal_all: np.ndarray,
    pass_index: np.ndarray,
    direction: np.ndarray,
    k_diag: np.ndarray,
    h_const: np.ndarray,
) -> LoopOutput:
    """Every sample of a replay to equilibrium, MuJoCo called per Newton iteration (any field, any model).

    Args:
        model, data: The twin's model and data (qpos and kinematics overwritten).
        tcp_site: Id of the `tcp` site.
        field: The twin's sheet field, reset (advanced sample by sample).
        solver: The equilibrium solver on `model` (its `p_base_sheet_origin` and `R_base_sheet` place the sheet).
        q_nominal_all: Unloaded poses (all joints) [rad], shape (n, nq).
        pass_index, direction: Pass and travel direction per sample.
        k_diag: Joint springs [N·m/rad], shape (nv,).
        h_const: K + dg/dq, the Newton matrix without the sheet term, shape (nv, nv).
    """
    m, d = model, data
    n = len(q_nominal_all)
    qpos_out = np.zeros((n, m.nq))
    p_out = np.zeros((n, 3))
    p_unloaded = np.zeros((n, 3))
    f_out = np.zeros((n, 3))
    iters = np.zeros(n, dtype=int)
    jac_last = np.zeros((n, 3, m.nv))
    s_last = np.zeros((n, 3, 3))
    g_nom = np.zeros(m.nv)
    qpos_view, qvel_view = d.qpos, d.qvel
    xpos_tcp = d.site_xpos[tcp_site]  # a view: follows every mj_kinematics
    origin, rot = solver.p_base_sheet_origin, solver.R_base_sheet

    def tip_sheet() -> np.ndarray:
        return xpos_tcp - origin if rot is None else rot.T @ (xpos_tcp - origin)

    passes = [int(v) for v in pass_index]
    dirs = [int(v) for v in direction]
    deflection_q = np.zeros(m.nq)
    deflection_prev = np.zeros(m.nq)
    qvel_view[:] = 0.0
    hold = not field.extrapolated_start
    for i in range(n):
        pi, di = passes[i], dirs[i]
        q_nominal = q_nominal_all[i]
        qpos_view[:] = q_nominal
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_rne(m, d, 0, g_nom)
        p_unloaded[i] = tip_sheet()
        q_ref = q_nominal + g_nom / k_diag  # taught under gravity
        # start from the deflection extrapolated from the last two samples of this pass (else the last one)
        if i >= 2 and passes[i - 2] == pi:
            q = q_nominal + (2.0 * deflection_q - deflection_prev)
        else:
            q = q_nominal + deflection_q
        if i == 0:
            q_link = q_nominal  # the taught, unloaded pose
        # a joint whose friction holds keeps its link where it was: its spring stretches by q_ref - q_link
        iterations = 0

        def equilibrium(
            sheet: SheetModel, q: np.ndarray = q, q_ref: np.ndarray = q_ref, e_prev: np.ndarray = q_ref - q_link
        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
            nonlocal iterations
            q_eq, k_eq, jac, stiffness = solver.solve(q, q_ref, k_diag, h_const, sheet, e_prev, hold)
            iterations += k_eq
            qpos_view[:] = q_eq
            mujoco.mj_kinematics(m, d)
            return q_eq, jac, stiffness, tip_sheet()

        # the tool's sliding friction is solved one regime at a time (process.tool_friction)
        q, jac_last[i], s_last[i], p = solve_sample(field, pi, di, equilibrium, lambda solution: solution[3])
        # the tip gain is that of a sliding tool: a command step that matters makes a sticking tool slide
        if isinstance(field, SlidingFriction):
            s_last[i, 0, 0] -= field.last_stick_stiffness
        q_link = q
        f_out[i] = field.force(p, pi, di)
        field.advance(p, pi)
        qpos_out[i], p_out[i], iters[i] = q, p, iterations
        deflection_prev, deflection_q = deflection_q, q - q_nominal
    return LoopOutput(qpos_out, p_out, p_unloaded, f_out, iters, jac_last, s_last)
