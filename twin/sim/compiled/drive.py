"""The dynamic twin's work around each `mj_step` (`twin.sim.dynamic.DynamicTwin.simulate`), compiled: before the
step, each arm joint's motor under its servo (the implicit-Euler PID step of `twin.sim.dynamic`'s docstring) and the
springs' references; between `mj_step1` and `mj_step2`, the sheet's linearised force at the moved tip and the gear
dampers' drive, applied as generalised forces.

MuJoCo's step is C, but the loop around it was numpy on six-element arrays: some twenty small calls a step, three
times the step itself (26 us against 6 us on the shared 2-core machine). Each function here is one call on arrays
made before the loop, in place; the arithmetic is the loop's, in its order.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Rows of `gains` (per arm joint): the rotor's inertia J_m, the PID gains K_p, K_i, K_d, the gear's damper c and
#: spring K_q, and the implicit step's denominator J_m / h + K_d + c + (K_p + K_q) h.
J_MOTOR, K_P, K_I, K_D, C_GEAR, K_GEAR, DENOM = range(7)
GAINS_SIZE = 7
#: Rows of `state` (per arm joint): the motor's angle θ, its speed ω and the integral of the error.
THETA, OMEGA, INTEGRAL = range(3)
STATE_SIZE = 3


def pack_gains(j_motor: np.ndarray, k_p: np.ndarray, k_i: np.ndarray, k_d: np.ndarray, c_gear: np.ndarray,
               k_gear: np.ndarray, h: float) -> np.ndarray:
    """`motor_step`'s `gains` (rows `J_MOTOR` .. `DENOM`, a column per arm joint) from each joint's rotor inertia
    [kg·m²], PID gains [N·m/rad, N·m/(rad·s), N·m·s/rad], gear damper [N·m·s/rad] and spring [N·m/rad], with the
    implicit step's denominator for the step `h` [s] worked out once."""
    gains = np.empty((GAINS_SIZE, len(j_motor)))
    gains[J_MOTOR], gains[K_P], gains[K_I], gains[K_D], gains[C_GEAR], gains[K_GEAR] = j_motor, k_p, k_i, k_d, c_gear, k_gear
    gains[DENOM] = j_motor / h + k_d + c_gear + (k_p + k_gear) * h  # implicit Euler: ω⁺ denom = J_m ω / h + ...
    return gains


def motor_state(theta: np.ndarray, omega: np.ndarray, integral: np.ndarray) -> np.ndarray:
    """`motor_step`'s `state` (rows `THETA`, `OMEGA`, `INTEGRAL`) from the motors' angles [rad], speeds [rad/s] and
    error integrals [rad·s]."""
    state = np.empty((STATE_SIZE, len(theta)))
    state[THETA], state[OMEGA], state[INTEGRAL] = theta, omega, integral
    return state


@njit(cache=True)
def motor_step(k, rigid, h, arm_ref, arm_rate, rate, ff, pas_ref, gains, state, arm, act, passive, qpos, qvel,
               ctrl, spring, drive):  # type: ignore[no-untyped-def]
    """Step k's motors and references, before `mj_step1`: the passive hinges' spring references, each arm joint's
    motor (θ on its reference where the servo is rigid), the position actuators' controls (θ) and the speeds the
    gear dampers act on (`drive`: the references' rate, the motors' ω on the arm)."""
    for i in range(passive.shape[0]):
        spring[passive[i]] = pas_ref[k, i]
    for i in range(drive.shape[0]):
        drive[i] = rate[k, i]
    for j in range(arm.shape[0]):
        if rigid:
            state[THETA, j] = arm_ref[k, j]
            state[OMEGA, j] = arm_rate[k, j]
        else:
            err = arm_ref[k, j] - state[THETA, j]
            state[INTEGRAL, j] += h * err
            num = (gains[J_MOTOR, j] * state[OMEGA, j] / h + gains[K_P, j] * err
                   + gains[K_I, j] * state[INTEGRAL, j] + gains[K_D, j] * arm_rate[k, j] + ff[k, j])
            num += gains[C_GEAR, j] * qvel[arm[j]] - gains[K_GEAR, j] * (state[THETA, j] - qpos[arm[j]])
            state[OMEGA, j] = num / gains[DENOM, j]
            state[THETA, j] += h * state[OMEGA, j]
        ctrl[act[j]] = state[THETA, j]
        drive[arm[j]] = state[OMEGA, j]


@njit(cache=True)
def contact_forces(k, tip, x_base, d_base, f_base, jacp, damping, drive, qfrc, qpos, tips, qpos_out,
                   force_out):  # type: ignore[no-untyped-def]
    """Step k's applied forces, between `mj_step1` and `mj_step2`: the sheet's f = f_qs + D (x − x_qs) at the tip
    through its Jacobian `jacp` (base frame), plus the gear dampers' c · drive; the tip, joints and force kept."""
    f = force_out[k]
    for i in range(3):
        f[i] = f_base[k, i] + (d_base[k, i, 0] * (tip[0] - x_base[k, 0]) + d_base[k, i, 1] * (tip[1] - x_base[k, 1])
                               + d_base[k, i, 2] * (tip[2] - x_base[k, 2]))
        tips[k, i] = tip[i]
    for c in range(qfrc.shape[0]):
        qfrc[c] = f[0] * jacp[0, c] + f[1] * jacp[1, c] + f[2] * jacp[2, c] + damping[c] * drive[c]
    for c in range(qpos.shape[0]):
        qpos_out[k, c] = qpos[c]
