"""`experiments/pyramid_corners.py`'s rounding of a corner, on a path written here: no sample turns past the turn at
which the plant's controller stops, the samples away from the corner stay, and the corner is cut by the quadratic
Bezier curve's own amount."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
from pyramid_corners import ROUND_MM, rounded, turns_deg

from twin.analysis.learn.servo_fit import CORNER_TURN_DEG, corner_indices


def _square_corner(step_mm: float = 0.41) -> np.ndarray:
    """Along x to (20, 0), then along y: a pyramid's corner, `step_mm` between samples [mm]."""
    along = np.arange(0.0, 20.0 + 1e-9, step_mm)
    first = np.c_[along, 0.0 * along, 0.0 * along]
    up = np.arange(step_mm, 20.0, step_mm)
    return np.vstack([first, np.c_[np.full_like(up, along[-1]), up, 0.0 * up]])


def test_a_rounded_corner_turns_nowhere_past_the_stop_and_keeps_the_rest_of_the_path() -> None:
    p = _square_corner()
    assert len(corner_indices(p)) == 1 and np.max(turns_deg(p)) == pytest.approx(90.0)
    q = rounded(p)
    assert q.shape == p.shape and len(corner_indices(q)) == 0
    assert np.max(turns_deg(q)) < CORNER_TURN_DEG
    k = corner_indices(p)[0]
    far = np.abs(np.arange(len(p)) - k) * 0.41 > ROUND_MM + 1e-9
    assert np.array_equal(q[far], p[far])
    # the Bezier curve's middle lies a quarter of |P0 + P2 - 2 P1| = reach * sqrt(2) / 4 from the corner
    assert np.linalg.norm(q[k] - p[k]) == pytest.approx(ROUND_MM * np.sqrt(2.0) / 4.0, rel=0.05)


def test_a_path_without_corners_is_left_as_it_is() -> None:
    s = np.linspace(0.0, 30.0, 80)
    p = np.c_[s, 0.1 * s, -0.01 * s]
    assert np.array_equal(rounded(p), p)
