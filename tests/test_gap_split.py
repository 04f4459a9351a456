"""Where a replay gap's robot part lies (`twin.analysis.learn.split`): its part above 0.5 Hz and its share near the
controller's stops, on gaps written here (`tests/test_learn.py` reads what `replay --forces measured` prints of
them on a plant run)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.analysis.learn.split import FAST_HZ, NEAR_STOP_S, controller_stops, fast_part_mm, near_stop_shares
from twin.runs.format import Run, Stream

RATE_HZ = 50.0  # a tracker's


def _sine_m(t_s: np.ndarray, amplitude_mm: float, hz: float) -> np.ndarray:
    return np.column_stack([1e-3 * amplitude_mm * np.sin(2.0 * np.pi * hz * t_s), np.zeros((len(t_s), 2))])


def test_the_fast_part_is_what_lies_above_half_a_hertz() -> None:
    t = np.arange(0.0, 60.0, 1.0 / RATE_HZ)
    slow, fast = _sine_m(t, 0.1, 0.1 * FAST_HZ), _sine_m(t, 0.05, 10.0 * FAST_HZ)
    assert fast_part_mm(t, fast) == pytest.approx(0.05 / np.sqrt(2.0), rel=0.02)
    assert fast_part_mm(t, slow) < 0.01 * 0.1
    assert fast_part_mm(t, slow + fast) == pytest.approx(fast_part_mm(t, fast), rel=0.02)


def _run_with_stops(stops_s: tuple[float, ...], t_end_s: float = 20.0) -> Run:
    """A straight command at 30 mm/s that halts for 0.1 s at each of `stops_s` (a controller's corner stops)."""
    t = np.arange(0.0, t_end_s, 0.004)
    speed = np.full(len(t), 0.03)
    for s in stops_s:
        speed[np.abs(t - s) < 0.05] = 0.0
    x = np.concatenate([[0.0], np.cumsum(speed[1:] * np.diff(t))])
    p = np.column_stack([x, np.zeros(len(t)), np.zeros(len(t))])
    return Run(None, {}, Stream(t, p), Stream(t[::5], p[::5]))


def test_the_share_near_the_stops_is_of_the_mean_square_and_of_the_samples() -> None:
    run = _run_with_stops((5.0, 10.0, 15.0))
    stops = controller_stops(run)
    assert np.all(np.min(np.abs(stops[:, None] - np.array([5.0, 10.0, 15.0])[None, :]), axis=1) < 0.06)
    t = run.tracker.t_s
    # within NEAR_STOP_S of a stopped sample: of the 0.1 s each stop lasts
    near = np.min(np.abs(t[:, None] - np.array([5.0, 10.0, 15.0])[None, :]), axis=1) < NEAR_STOP_S + 0.05
    at_stops = np.where(near[:, None], [1e-4, 0.0, 0.0], 0.0)  # a gap only near the stops
    share, samples = near_stop_shares(run, t, at_stops)
    assert share == pytest.approx(1.0) and samples == pytest.approx(np.mean(near), abs=0.01)
    assert samples == pytest.approx(3 * (2 * NEAR_STOP_S + 0.1) / 20.0, abs=0.01)
    even = np.full((len(t), 3), 1e-4)  # a gap spread evenly: its share is the samples'
    assert near_stop_shares(run, t, even)[0] == pytest.approx(samples, abs=1e-9)
    assert near_stop_shares(_run_with_stops(()), t, even) == (0.0, 0.0)  # no stop
