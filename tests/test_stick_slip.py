"""The robot learner's friction that sticks (`twin.analysis.learn.stick_slip`): the play operator, and a spring and
friction hidden in data the test writes itself (its own stick-slip loop, not the library's) found again."""

from __future__ import annotations

import numpy as np
import pytest

from twin.analysis.learn.stick_slip import FRICTION_MAX_NM, JointRows, play, refine


def test_the_play_follows_only_beyond_its_half_width() -> None:
    u = np.concatenate([np.linspace(0.0, 1.0, 11), np.linspace(0.9, 0.0, 10)])
    out = play(u, 0.25)
    assert out[0] == 0.0 and out[2] == 0.0  # within the play: held
    assert out[10] == pytest.approx(0.75)  # rising: lags by the half-width
    assert out[11] == out[12] == pytest.approx(0.75)  # turned back: held until u is 0.25 below
    assert out[-1] == pytest.approx(0.25)


def _hidden_rows(c: float, friction_nm: float, seed: int = 3) -> JointRows:
    """One joint turning slowly back and forth under a load that turns; the link sticks while the friction holds
    it (written here as the test's own loop); the tool tip moves 0.3 m per rad along x."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 60.0, 0.02)
    q = 0.02 * np.sin(2 * np.pi * t / 12.0)
    torque = 2000.0 + 1500.0 * np.sin(2 * np.pi * t / 7.0 + 0.4)
    link = np.empty_like(q)
    held = q[0] + c * torque[0]
    for i in range(len(t)):
        free = q[i] + c * torque[i]  # where the link would sit without friction
        if free - held > c * friction_nm:
            held = free - c * friction_nm
        elif held - free > c * friction_nm:
            held = free + c * friction_nm
        link[i] = held
    jac = np.zeros((len(t), 3, 1))
    jac[:, 0, 0] = 0.3
    deflection = np.zeros((len(t), 3))
    deflection[:, 0] = 0.3 * (link - q) + rng.normal(0.0, 2e-6, len(t))
    deflection[:, 1:] = rng.normal(0.0, 2e-6, (len(t), 2))
    return JointRows(t, q[:, None], jac, torque[:, None], deflection, np.zeros((3 * len(t), 0)))


def test_a_hidden_spring_and_sticking_friction_are_found_with_a_spread_that_covers_them() -> None:
    c_true, f_true = 1.0 / 300e3, 150.0  # 300 kN·m/rad, 150 N·m: the link sticks for a good part of each turn
    rows = _hidden_rows(c_true, f_true)
    c0 = np.array([1.0 / 200e3])
    fit = refine([rows], np.array([1.0 / 380e3]), np.array([20.0]), np.array([True]), c0)  # a stiff, frictionless start
    assert fit.c[0] == pytest.approx(c_true, rel=0.02) and fit.friction_nm[0] == pytest.approx(f_true, rel=0.05)
    assert abs(fit.c[0] - c_true) <= 2.0 * fit.c_std[0] and fit.c_std[0] < 0.15 * fit.c[0]
    assert fit.rms_mm[0] < 0.01  # down to the noise (2 um per axis)


def test_a_joint_the_run_does_not_move_cannot_trade_its_spring_for_endless_friction() -> None:
    rows = _hidden_rows(1.0 / 300e3, 150.0)
    still = rows._replace(q=np.zeros_like(rows.q))
    c0 = np.array([1.0 / 200e3])
    fit = refine([still], np.array([1.0 / 300e3]), np.array([100.0]), np.array([True]), c0)
    assert fit.friction_nm[0] <= FRICTION_MAX_NM * (1 + 1e-9) and 0.05 * c0[0] <= fit.c[0] <= 20.0 * c0[0]
