# mypy: disable-error-code="arg-type, assignment, return-value"
# (numba kernels: the numpy scalars they pass, typed non-literal on purpose, are not the annotated builtins)
"""The twin's per-sample replay loop in compiled code: equilibrium, joint friction, tool stick, field.

One compiled call runs what `Twin.simulate`'s Python loop does sample by sample, with the same algorithm and
the same decisions (`twin.sim.equilibrium.EquilibriumSolver`, `twin.process.force.tool_friction.solve_sample`):

* per sample, the unloaded pose's gravity, the set-points q_ref = q_ik + K⁻¹ g, the start point extrapolated
  from the pass's last two deflections;
* the tool's sliding friction one regime at a time (sliding as commanded, in the stick band, sliding back);
* in each regime the joint-friction active set (predicted from the start point), each round a Newton
  iteration on K (q_ref − q) + τ_fr − g(q) + J(q)ᵀ f(p(q)) = 0 with the chain of `twin.sim.compiled.chain`;
* the force at the equilibrium, then the field advances: the table field's formed profile and the slip state
  (`twin.sim.compiled.field`), or the ISF model's height map, travel direction and wall angle
  (`twin.sim.compiled.isf`; `kind` 1).

`replay_loop` returns (status, sample): status 0 done, 1 a singular Newton matrix at `sample`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from twin.sim.compiled.chain import ChainArrays, chain_eval, chain_tip
from twin.sim.compiled.field import FieldArrays, field_advance, field_force
from twin.sim.compiled.isf import IsfArrays, isf_advance_from, isf_eval
from twin.sim.compiled.sheet import frame_give, sheet
from twin.sim.compiled.work import Work, solve_linear

NEWTON_TOL_RAD = 1e-7
NEWTON_MAX_ITER = 40
NEWTON_DAMPED_AFTER = 10
FRICTION_MAX_ROUNDS = 6


@njit(cache=True)
def _newton(
    C: ChainArrays, F: FieldArrays, M: IsfArrays, kind: int, cur: int, mode: int, slip: float, x_prev: float, gain: float,
    frame: float, pass_index: int, direction: int, q: np.ndarray, q_ref: np.ndarray, k_diag: np.ndarray,
    h_const: np.ndarray, use_stick: bool, stuck: np.ndarray, e_stuck: np.ndarray, tau_fr: np.ndarray,
    choose: bool, tau_f: np.ndarray, jac: np.ndarray, S: np.ndarray, W: Work,
) -> tuple:
    """`EquilibriumSolver._newton`: q is updated in place; `stuck` and `tau_fr` too when `choose`.

    Returns:
        (iterations, status 0 or 1 for a singular matrix, stick stiffness of the last evaluation [N/m]).
    """
    nv = q.shape[0]
    p, g, f, r, h, dq, jtf, sj, base, free, demand = W.p, W.g, W.f, W.r, W.h, W.dq, W.jtf, W.sj, W.base, W.free, W.demand
    for j in range(nv):
        base[j] = k_diag[j] * q_ref[j]
        free[j] = 1.0
    stick = 0.0
    it = 0
    for it in range(1, NEWTON_MAX_ITER + 1):
        chain_eval(C, q, p, jac, g)
        stick = sheet(F, M, kind, cur, mode, slip, x_prev, gain, frame, p, pass_index, direction, f, S)
        for j in range(nv):
            jtf[j] = jac[0, j] * f[0] + jac[1, j] * f[1] + jac[2, j] * f[2]
            for row in range(3):
                sj[row, j] = S[row, 0] * jac[0, j] + S[row, 1] * jac[1, j] + S[row, 2] * jac[2, j]
        if use_stick and it == 1:
            if choose:
                for j in range(nv):
                    need = g[j] - jtf[j] - k_diag[j] * e_stuck[j]
                    stuck[j] = tau_f[j] > 0.0 and abs(need) <= tau_f[j]
                    tau_fr[j] = 0.0 if stuck[j] else tau_f[j] * np.sign(need)
            for j in range(nv):
                if stuck[j]:
                    base[j] = k_diag[j] * (q_ref[j] - e_stuck[j])
                    free[j] = 0.0
                else:
                    base[j] += tau_fr[j]
        for a in range(nv):
            r[a] = base[a] - k_diag[a] * q[a] + free[a] * (jtf[a] - g[a])
            if use_stick and stuck[a]:
                for b in range(nv):
                    h[a, b] = 0.0
                h[a, a] = k_diag[a]
            else:
                for b in range(nv):
                    h[a, b] = h_const[a, b] - (jac[0, a] * sj[0, b] + jac[1, a] * sj[1, b] + jac[2, a] * sj[2, b])
        for j in range(nv):
            demand[j] = g[j] - jtf[j]
        if not solve_linear(h, r, dq):
            return it, 1, stick
        step = 0.0
        for j in range(nv):
            if it > NEWTON_DAMPED_AFTER:
                dq[j] *= 0.5
            q[j] += dq[j]
            step = max(step, abs(dq[j]))
        if step < NEWTON_TOL_RAD:
            break
    return it, 0, stick


@njit(cache=True)
def _equilibrium(
    C: ChainArrays, F: FieldArrays, M: IsfArrays, kind: int, cur: int, mode: int, slip: float, x_prev: float, gain: float,
    frame: float, pass_index: int, direction: int, q: np.ndarray, q_ref: np.ndarray, k_diag: np.ndarray,
    h_const: np.ndarray, e_prev: np.ndarray, tau_f: np.ndarray, predict: bool, hold: bool, jac: np.ndarray,
    S: np.ndarray, W: Work,
) -> tuple:
    """`EquilibriumSolver.solve` (q in place). Returns (iterations, status, stick stiffness [N/m])."""
    nv = q.shape[0]
    demand, stuck, tau_fr = W.demand, W.stuck, W.tau_fr
    frictional = False
    for j in range(nv):
        stuck[j] = tau_f[j] > 0.0
        tau_fr[j] = 0.0
        if stuck[j]:
            frictional = True
    NO = np.bool_(False)
    if not frictional:
        return _newton(C, F, M, kind, cur, mode, slip, x_prev, gain, frame, pass_index, direction, q, q_ref, k_diag,
                       h_const, NO, stuck, e_prev, tau_fr, NO, tau_f, jac, S, W)
    if predict and hold:
        for j in range(nv):
            if tau_f[j] > 0.0:
                q[j] = q_ref[j] - e_prev[j]
    choose = np.bool_(predict)
    NO, YES = np.bool_(False), np.bool_(True)
    total = 0
    stick = 0.0
    for _ in range(FRICTION_MAX_ROUNDS):
        k, status, stick = _newton(C, F, M, kind, cur, mode, slip, x_prev, gain, frame, pass_index, direction, q, q_ref,
                                   k_diag, h_const, YES, stuck, e_prev, tau_fr, choose, tau_f, jac, S, W)
        total += k
        if status != 0:
            return total, status, stick
        choose = NO
        change = False
        for j in range(nv):
            need = demand[j] - k_diag[j] * e_prev[j]
            slip_j = stuck[j] and abs(need) > tau_f[j]
            back = (not stuck[j]) and (q_ref[j] - q[j] - e_prev[j]) * tau_fr[j] < 0.0
            if slip_j:
                stuck[j] = False
                tau_fr[j] = tau_f[j] * np.sign(need)
                change = True
            elif back:
                stuck[j] = True
                tau_fr[j] = 0.0
                change = True
        if not change:
            break
    return total, 0, stick


@njit(cache=True)
def replay_loop(
    C: ChainArrays, F: FieldArrays, M: IsfArrays, kind: int, q_nominal: np.ndarray, passes: np.ndarray, dirs: np.ndarray,
    k_diag: np.ndarray, h_const: np.ndarray, tau_f: np.ndarray, predict: bool, hold: bool,
    friction: bool, gain: float, frame: float, qpos_out: np.ndarray, p_out: np.ndarray, p_unloaded: np.ndarray,
    f_out: np.ndarray, iters: np.ndarray, jac_out: np.ndarray, s_out: np.ndarray, state: np.ndarray, W: Work,
) -> tuple:
    """`Twin.simulate`'s per-sample loop over every sample, outputs in the `*_out` arrays.

    Args:
        hold: `EquilibriumSolver.solve`'s `hold` (False: the force model's `extrapolated_start`).
        friction: The tool's sliding friction (`SlidingFriction` of reversal travel 2 / `gain` [m]) wraps the field.
        state: Out: (current pass, slip state, last tip x [m], first direction) after the last sample.

    Returns:
        (status, sample): status 0 done, 1 a singular Newton matrix at `sample`.
    """
    n, nv = q_nominal.shape
    p = np.empty(3)
    g_nom = np.empty(nv)
    jac = np.zeros((3, nv))
    jac_nom = np.zeros((3, nv))  # the Jacobian of the last Newton iteration stays in `jac`
    S = np.zeros((3, 3))
    q_ref = np.empty(nv)
    q_link = q_nominal[0].copy()
    defl = np.zeros(nv)
    defl_prev = np.zeros(nv)
    e_prev = np.empty(nv)
    q = np.empty(nv)
    q_try = np.empty(nv)
    f_eq, S_eq = np.empty(3), np.empty((3, 3))
    fy, vx, vy = 0.0, 0.0, 0.0
    cur, ZERO, ONE = np.int64(0), np.int64(0), np.int64(1)  # typed, not literal: one compiled version each
    slip, x_prev, first_dir = 0.0, 0.0, 0
    for i in range(n):
        pi, di = passes[i], dirs[i]
        qn = q_nominal[i]
        chain_eval(C, qn, p, jac_nom, g_nom)
        for r in range(3):
            p_unloaded[i, r] = p[r]
        for j in range(nv):
            q_ref[j] = qn[j] + g_nom[j] / k_diag[j]
            if i >= 2 and passes[i - 2] == pi:
                q[j] = qn[j] + 2.0 * defl[j] - defl_prev[j]
            else:
                q[j] = qn[j] + defl[j]
            e_prev[j] = q_ref[j] - q_link[j]
        total = 0
        stick = 0.0
        if not friction or i == 0:
            for j in range(nv):
                q_try[j] = q[j]
            k, status, stick = _equilibrium(C, F, M, kind, cur, ZERO, slip, x_prev, gain, frame, pi, di, q_try, q_ref, k_diag,
                                            h_const, e_prev, tau_f, predict, hold, jac, S, W)
            total += k
            if status != 0:
                return status, i
            stick = 0.0
            chain_tip(C, q_try, p)
            if i == 0:
                first_dir = di
        else:
            for attempt in range(3):
                regime = float(di) if attempt == 0 else (0.0 if attempt == 1 else -float(di))
                mode = ONE if regime == 0.0 else ZERO
                sign = di if attempt == 0 else -di
                for j in range(nv):
                    q_try[j] = q[j]
                k, status, stick = _equilibrium(C, F, M, kind, cur, mode, slip, x_prev, gain, frame, pi, sign, q_try, q_ref,
                                                k_diag, h_const, e_prev, tau_f, predict, hold, jac, S, W)
                total += k
                if status != 0:
                    return status, i
                if mode == 0:
                    stick = 0.0
                chain_tip(C, q_try, p)
                u = slip + gain * (p[0] - x_prev)
                if (regime == 0.0 and -1.0 <= u <= 1.0) or (regime != 0.0 and u * regime >= 1.0):
                    break
        # the force at the equilibrium (not in the band: the slip state clipped), the sheet met where the frame gave
        x, z = p[0], p[2] + frame_give(F, M, kind, cur, ZERO, slip, x_prev, gain, frame, p, pi, ONE, f_eq, S_eq)
        if kind == 1:
            vx, vy = isf_eval(M, x, p[1], z, f_eq, S_eq)
            fx, fy, fz = f_eq[0], f_eq[1], f_eq[2]
        elif friction and i > 0:
            s = slip + gain * (x - x_prev)
            s = 1.0 if s >= 1.0 else (-1.0 if s <= -1.0 else s)
            if s == 1.0 or s == -1.0:
                fx, fz = field_force(F, cur, x, z, pi, np.int64(s))
            else:
                fx, fz = field_force(F, cur, x, z, pi, ONE)
                fx *= s
        else:
            fx, fz = field_force(F, cur, x, z, pi, di)
        if kind != 1:
            fy = 0.0
        f_out[i, 0], f_out[i, 1], f_out[i, 2] = fx, fy, fz
        for r in range(3):
            for c in range(3):
                s_out[i, r, c] = S[r, c]
            p_out[i, r] = p[r]
        s_out[i, 0, 0] -= stick
        for r in range(3):  # element by element: an array copy compiles its shape check's message (seconds)
            for j in range(nv):
                jac_out[i, r, j] = jac[r, j]
        if friction:
            slip = float(first_dir) if i == 0 else min(1.0, max(-1.0, slip + gain * (x - x_prev)))
            x_prev = x
        if kind == 1:
            isf_advance_from(M, x, p[1], z, f_eq[2], vx, vy)
        else:
            cur = field_advance(F, cur, x, z, pi)
        for j in range(nv):
            qpos_out[i, j] = q_try[j]
            defl_prev[j] = defl[j]
            defl[j] = q_try[j] - qn[j]
            q_link[j] = q_try[j]
        iters[i] = total
    state[0], state[1], state[2], state[3] = float(cur), slip, x_prev, float(first_dir)
    return 0, n
