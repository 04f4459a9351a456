"""The dynamic twin's compiled work around each `mj_step` (`twin.sim.compiled.drive`, its gains packed by `pack_gains`)
against the step written here in numpy from `twin.sim.dynamic`'s docstring: the motor's implicit-Euler PID step, J_m
ω⁺/h + ... = ω⁺ denom, and the sheet's linearised force f = f_qs + D (x − x_qs) applied through the tip's Jacobian
with the gear dampers' drive."""

from __future__ import annotations

import numpy as np
import pytest

from twin.sim.compiled.drive import (
    INTEGRAL,
    OMEGA,
    THETA,
    contact_forces,
    motor_state,
    motor_step,
    pack_gains,
)

ARM, PASSIVE, NV, STEPS, H = np.array([0, 1, 3, 4, 5, 7]), np.array([2, 6]), 8, 5, 1e-3


def _inputs(seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    n = len(ARM)
    jm, kp, ki = rng.uniform(0.5, 2, n), rng.uniform(1e4, 1e5, n), rng.uniform(1e5, 1e6, n)
    kd, c, kq = rng.uniform(10, 100, n), rng.uniform(1, 50, n), rng.uniform(1e5, 1e6, n)
    state = motor_state(rng.normal(0, 0.1, n), rng.normal(0, 0.01, n), rng.normal(0, 1e-4, n))
    return {"jm": jm, "kp": kp, "ki": ki, "kd": kd, "c": c, "kq": kq, "gains": pack_gains(jm, kp, ki, kd, c, kq, H),
            "arm_ref": rng.normal(0, 0.1, (STEPS, n)), "arm_rate": rng.normal(0, 0.1, (STEPS, n)),
            "rate": rng.normal(0, 0.1, (STEPS, NV)), "ff": rng.normal(0, 50, (STEPS, n)),
            "pas_ref": rng.normal(0, 1e-3, (STEPS, len(PASSIVE))), "state": state,
            "qpos": rng.normal(0, 0.1, NV), "qvel": rng.normal(0, 0.01, NV)}


@pytest.mark.parametrize("rigid", [False, True])
def test_the_motor_step_is_the_implicit_euler_pid_step(rigid: bool) -> None:
    given, k = _inputs(1), 3
    s0 = given["state"].copy()
    ctrl, spring, drive = np.full(len(ARM) + 1, np.nan), np.zeros(NV), np.full(NV, np.nan)
    act = np.arange(len(ARM)) + 1  # the actuators after one that is not the arm's
    motor_step(k, rigid, H, given["arm_ref"], given["arm_rate"], given["rate"], given["ff"], given["pas_ref"],
               given["gains"], given["state"], ARM, act, PASSIVE, given["qpos"], given["qvel"], ctrl, spring, drive)
    if rigid:
        theta, omega, integral = given["arm_ref"][k], given["arm_rate"][k], s0[INTEGRAL]
    else:
        err = given["arm_ref"][k] - s0[THETA]
        integral = s0[INTEGRAL] + H * err
        jm, kp, ki, kd, c, kq = (given[key] for key in ("jm", "kp", "ki", "kd", "c", "kq"))
        rhs = (jm * s0[OMEGA] / H + kp * err + ki * integral + kd * given["arm_rate"][k] + given["ff"][k]
               + c * given["qvel"][ARM] - kq * (s0[THETA] - given["qpos"][ARM]))
        omega = rhs / (jm / H + kd + c + (kp + kq) * H)  # J_m ω⁺/h = rhs - (K_d + c + (K_p + K_q) h) ω⁺
        theta = s0[THETA] + H * omega
    np.testing.assert_allclose(given["state"][THETA], theta, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(given["state"][OMEGA], omega, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(given["state"][INTEGRAL], integral, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(ctrl[act], given["state"][THETA])
    assert np.isnan(ctrl[0])  # an actuator that is not the arm's is left alone
    expected_drive = given["rate"][k].copy()
    expected_drive[ARM] = given["state"][OMEGA]
    np.testing.assert_array_equal(drive, expected_drive)
    np.testing.assert_array_equal(spring[PASSIVE], given["pas_ref"][k])
    assert not np.any(np.delete(spring, PASSIVE))


def test_the_contact_forces_are_the_linearised_sheet_through_the_jacobian_and_the_dampers() -> None:
    rng = np.random.default_rng(2)
    k = 2
    tip, x_base, f_base = rng.normal(0, 1, 3), rng.normal(0, 1, (STEPS, 3)), rng.normal(0, 500, (STEPS, 3))
    d_base, jacp = rng.normal(0, 1e5, (STEPS, 3, 3)), rng.normal(0, 1, (3, NV))
    damping, drive, qpos = rng.uniform(0, 50, NV), rng.normal(0, 0.1, NV), rng.normal(0, 0.1, NV)
    qfrc, tips, qpos_out, force = np.zeros(NV), np.zeros((STEPS, 3)), np.zeros((STEPS, NV)), np.zeros((STEPS, 3))
    contact_forces(k, tip, x_base, d_base, f_base, jacp, damping, drive, qfrc, qpos, tips, qpos_out, force)
    f = f_base[k] + d_base[k] @ (tip - x_base[k])
    np.testing.assert_allclose(force[k], f, rtol=1e-12)
    np.testing.assert_allclose(qfrc, f @ jacp + damping * drive, rtol=1e-10, atol=1e-9)
    np.testing.assert_array_equal(tips[k], tip)
    np.testing.assert_array_equal(qpos_out[k], qpos)
    assert not np.any(np.delete(force, k, axis=0)) and not np.any(np.delete(tips, k, axis=0))
