"""Tests of the sliding direction of the ISF model's in-plane force (twin/process/force/sliding.py) and of the
groove history's turns put back between samples (ForceHistory.turns, isf_calibration.history_drive)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twin.process.fe.load import default_force_history
from twin.process.force.isf_calibration import history_drive
from twin.process.force.sliding import RELEASE_LENGTH_M, sliding_direction
from twin.process.toolpath.groove import groove_path

L_F = 1e-3


def numeric_jacobian(v_prev: tuple[float, float], dx: float, dy: float, h: float = 1e-10) -> np.ndarray:
    out = np.zeros((2, 2))
    for j, (ex, ey) in enumerate(((h, 0.0), (0.0, h))):
        plus = sliding_direction(v_prev, dx + ex, dy + ey, L_F, RELEASE_LENGTH_M)[:2]
        minus = sliding_direction(v_prev, dx - ex, dy - ey, L_F, RELEASE_LENGTH_M)[:2]
        out[:, j] = (np.array(plus) - np.array(minus)) / (2 * h)
    return out


@pytest.mark.parametrize(
    ("v_prev", "step"),
    [
        ((1.0, 0.0), (4e-4, 1e-5)),  # straight on
        ((0.6, -0.8), (2e-4, 3e-4)),  # a turn of less than 90°
        ((1.0, 0.0), (-3e-4, 1e-4)),  # a reversal: released
        ((0.8, 0.6), (-4e-5, -1e-5)),  # a short step back: partly released
        ((1.0, 0.0), (-2e-6, 5e-7)),  # jitter back: almost nothing released
    ],
)
def test_jacobian_matches_central_differences(v_prev, step) -> None:
    _, _, jac = sliding_direction(v_prev, *step, L_F, RELEASE_LENGTH_M)
    assert jac is not None
    numeric = numeric_jacobian(v_prev, *step)
    np.testing.assert_allclose(jac, numeric, rtol=1e-5, atol=1e-6 * np.abs(numeric).max())


def run(v: tuple[float, float], steps: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out = []
    for dx, dy in steps:
        vx, vy, _ = sliding_direction(v, dx, dy, L_F, RELEASE_LENGTH_M)
        v = (vx, vy)
        out.append(v)
    return out


def test_a_straight_run_keeps_the_full_direction() -> None:
    v = run((0.0, 0.0), [(2e-4, 0.0)] * 100)[-1]
    assert v[0] == pytest.approx(1.0, abs=1e-8) and v[1] == 0.0


def test_a_reversal_drops_the_force_to_zero_and_builds_it_up_over_the_turn_length() -> None:
    step = 0.25e-3  # 5 release lengths: the first step back releases 99.3 % of the held direction
    history = run((1.0, 0.0), [(-step, 0.0)] * 20)
    u = step * np.arange(1, 21)
    vx = np.array([v[0] for v in history])
    expected = -(1.0 - np.exp(-u / L_F))  # from zero at the reversal, built up against the new travel
    np.testing.assert_allclose(vx, expected, atol=0.01)
    assert run((1.0, 0.0), [(-2e-4, 0.0)] * 20)[-1][0] == pytest.approx(-1.0, abs=0.02)


def test_a_right_angle_turn_releases_nothing() -> None:
    step = 0.2e-3
    vx, vy, _ = sliding_direction((1.0, 0.0), 0.0, step, L_F, RELEASE_LENGTH_M)
    w = math.exp(-step / L_F)
    assert (vx, vy) == pytest.approx((w, 1.0 - w), abs=1e-12)


def test_jitter_back_keeps_the_held_direction() -> None:
    vx, _, _ = sliding_direction((1.0, 0.0), -1e-6, 0.0, L_F, RELEASE_LENGTH_M)
    assert vx > 0.97  # a 1 µm wobble of a deflecting tool is no reversal
    assert sliding_direction((0.3, 0.4), 0.0, 1e-12, L_F, RELEASE_LENGTH_M) == (0.3, 0.4, None)


def test_the_groove_history_gets_its_nine_reversal_corners_back() -> None:
    history = default_force_history()
    assert history.turns().sum() == 9
    drive, rows = history_drive(history)
    assert len(drive) == len(history.s_m) + 9
    np.testing.assert_array_equal(drive.p_sheet_m[rows], history.p_sheet_m)
    corners = np.setdiff1d(np.arange(len(drive)), rows)
    ideal = groove_path()
    reversals = ideal.p_sheet_m[np.flatnonzero(np.diff(ideal.pass_index) != 0)]
    x_extremes = reversals[np.abs(reversals[:, 0]) > 1e-3]  # the corners at the stroke ends
    for corner in drive.p_sheet_m[corners]:
        assert np.min(np.linalg.norm(x_extremes - corner, axis=1)) < 5e-6  # within 5 µm of the true corner


def test_the_sample_just_past_a_corner_belongs_to_the_next_pass() -> None:
    history = default_force_history()
    pass_index, direction = history.pass_labels()
    first = np.flatnonzero(np.diff(pass_index) != 0)
    assert len(first) == 9
    fx = history.f_sheet_n[:, 0]
    # every sample's Fx opposes its labelled travel, or is within 20 N of zero (right at a corner)
    assert np.all((fx * direction <= 0.0) | (np.abs(fx) < 20.0))


@pytest.mark.parametrize("step", [(4e-4, 1e-5), (-3e-4, 1e-4), (-4e-5, -1e-5), (0.0, 2e-4)])
def test_the_direction_without_its_jacobian_is_the_same(step) -> None:
    full = sliding_direction((0.8, 0.6), *step, L_F, RELEASE_LENGTH_M)
    alone = sliding_direction((0.8, 0.6), *step, L_F, RELEASE_LENGTH_M, jacobian=False)
    assert alone[2] is None and alone[:2] == pytest.approx(full[:2], abs=1e-15)
