"""The dynamic plant's trajectory generator stops at sharp corners with a limited acceleration."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import InputError
from twin.lab.dynamic.trajectory import retime_with_stops, stop_indices


def _zigzag(feed_mps: float = 2.0 / 60.0, step_m: float = 5e-4) -> tuple[np.ndarray, np.ndarray]:
    x = np.concatenate([np.arange(0.0, 0.03 + 1e-12, step_m), np.arange(0.03 - step_m, -1e-12, -step_m)])
    p = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    return np.arange(len(x)) * step_m / feed_mps, p


def test_stops_are_the_ends_and_the_reversal_not_a_gentle_bend():
    _, p = _zigzag()
    assert stop_indices(p).tolist() == [0, 60, len(p) - 1]
    theta = np.linspace(0.0, np.pi, 200)  # a half circle: 0.9 deg per segment, no stop inside
    arc = np.column_stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)])
    assert stop_indices(arc).tolist() == [0, 199]


def test_speed_ramps_to_rest_at_a_stop_and_cruises_at_the_programmed_feed():
    t, p = _zigzag()
    accel = 0.5
    t_new = retime_with_stops(t, p, accel)
    v = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(t_new)
    feed = 2.0 / 60.0
    assert np.max(v) <= feed * (1 + 1e-12)
    ramp_m = feed**2 / (2 * accel)  # 1.1 mm
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    mid = 0.5 * (s[1:] + s[:-1])
    cruise = (np.abs(mid - s[60]) > ramp_m + 5e-4) & (mid > ramp_m + 5e-4) & (mid < s[-1] - ramp_m - 5e-4)
    np.testing.assert_allclose(v[cruise], feed, rtol=1e-12)
    # the segment leaving the reversal: exact time from rest over 0.5 mm at 0.5 m/s^2
    assert t_new[61] - t_new[60] == pytest.approx(np.sqrt(2 * 5e-4 / accel), rel=1e-12)
    # each of the four ramps (start, into and out of the reversal, end) costs v / (2 a) over the programmed timing
    assert t_new[-1] - t[-1] == pytest.approx(4 * feed / (2 * accel), rel=0.05)


def test_zero_acceleration_keeps_the_programmed_times():
    t, p = _zigzag()
    np.testing.assert_array_equal(retime_with_stops(t, p, 0.0), t)


def test_bad_timing_is_refused():
    t, p = _zigzag()
    with pytest.raises(InputError, match="increasing"):
        retime_with_stops(t[::-1], p, 0.5)
