"""Tests of the measurement model shared by the lab and replay (twin/sim/measure.py)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.analysis.replay import ReplayResult
from twin.base.signals import uniform_times
from twin.process.force.table import K_UNLOAD_N_PER_M
from twin.process.part.springback import PROFILE_HALF_SPAN_M, PROFILE_SPACING_M
from twin.sim.effects import TRACKER_DRIFT_DIRECTION, Effects
from twin.sim.measure import predict_forces, predict_part_profile, predict_tracker
from twin.sim.quasi_static import Twin


def test_uniform_times_start_at_zero_and_include_the_end() -> None:
    t = uniform_times(2.0, 50.0)
    assert len(t) == 101
    assert t[0] == 0.0 and t[-1] == pytest.approx(2.0)
    np.testing.assert_allclose(np.diff(t), 0.02)
    assert uniform_times(2.019, 50.0)[-1] == pytest.approx(2.0)
    assert len(uniform_times(0.0, 30.0)) == 1


def test_tracker_reads_the_simulated_tip_without_effects(clean_replay: ReplayResult) -> None:
    sim = clean_replay.sim
    np.testing.assert_allclose(predict_tracker(sim, sim.t_s[::7], Effects()), sim.p_sheet_m[::7], atol=1e-12)
    t_mid = 0.5 * (sim.t_s[100] + sim.t_s[101])
    np.testing.assert_allclose(
        predict_tracker(sim, np.array([t_mid]), Effects())[0], 0.5 * (sim.p_sheet_m[100] + sim.p_sheet_m[101])
    )


def test_tracker_drift_grows_linearly_with_time_along_its_direction(clean_replay: ReplayResult) -> None:
    sim = clean_replay.sim
    t_s = np.array([0.0, 5.0, 10.0, 19.0])
    drift = predict_tracker(sim, t_s, Effects({"tracker_drift": 0.02})) - predict_tracker(sim, t_s, Effects())
    np.testing.assert_allclose(drift, np.outer(t_s, 2e-5 * TRACKER_DRIFT_DIRECTION), atol=1e-15)
    assert np.linalg.norm(drift[-1]) == pytest.approx(19.0 * 0.02e-3)


def test_force_stream_offset_reads_the_force_tau_earlier(
    twin_nominal: Twin, clean_replay: ReplayResult
) -> None:
    sim = clean_replay.sim
    t_s = np.arange(0.0, 6.0, 1.0 / 30.0)
    plain = predict_forces(twin_nominal, sim, t_s, Effects())
    np.testing.assert_allclose(plain, twin_nominal.sensor_forces(sim, t_s), atol=1e-9)
    late = predict_forces(twin_nominal, sim, t_s, Effects({"stream_time_offset": 0.2}))
    np.testing.assert_allclose(late[6:], plain[:-6], atol=1e-6)  # 0.2 s = 6 samples at 30 Hz
    np.testing.assert_allclose(late[:6], np.tile(plain[0], (6, 1)), atol=1e-6)  # clamped to the run start
    assert np.abs(late - plain).max() > 50.0


def test_part_profile_is_the_formed_bottom_after_elastic_recovery(
    twin_nominal: Twin, clean_replay: ReplayResult
) -> None:
    sim = clean_replay.sim
    x_m, z_m = predict_part_profile(twin_nominal, sim, Effects())
    assert x_m[0] == pytest.approx(-PROFILE_HALF_SPAN_M) and x_m[-1] == pytest.approx(PROFILE_HALF_SPAN_M)
    np.testing.assert_allclose(np.diff(x_m), PROFILE_SPACING_M)
    loaded = np.interp(x_m, sim.formed_x_m, sim.formed_z_m)
    recovery = z_m - loaded
    assert np.all(recovery >= -1e-12)  # springback only lifts the bottom
    # at the centre the last pass pressed with its force Fz; the bottom rises by Fz / k_unload
    centre = int(np.argmin(np.abs(x_m)))
    last = np.flatnonzero(sim.pass_index == sim.pass_index.max())
    order = np.argsort(sim.p_sheet_m[last, 0])
    fz_centre = float(np.interp(0.0, sim.p_sheet_m[last, 0][order], sim.f_sheet_n[last, 2][order]))
    assert recovery[centre] == pytest.approx(fz_centre / K_UNLOAD_N_PER_M, rel=0.05)
    assert -0.0085 < z_m.min() < -0.005  # 10 mm commanded, shallower by the deflection and the springback
    assert abs(z_m[0]) < 1e-4 and abs(z_m[-1]) < 1e-4  # flat sheet outside the groove
    x_back, z_back = predict_part_profile(twin_nominal, sim, Effects({"sheet_springback": 0.13}))
    np.testing.assert_array_equal(x_back, x_m)
    np.testing.assert_allclose(z_back, 0.87 * z_m)
