"""Tests of the ideal groove path (twin/process/toolpath/groove.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from twin.base.csvio import read_table
from twin.cli import main
from twin.errors import InputError
from twin.process.toolpath.groove import (
    GrooveSpec,
    groove_path,
    label_passes,
    resample_by_arc_length,
)
from twin.runs.write import write_path_csv


def _pass_ends(path, spec):
    """(x_start, x_end) of each pass's forming run (turn excluded)."""
    h = spec.step_down_m
    out = []
    for k in range(1, spec.passes + 1):
        idx = np.flatnonzero(path.pass_index == k)
        z = path.p_sheet_m[idx, 2]
        start = idx[np.flatnonzero(np.isclose(z, -(k - 1) * h, atol=1e-12))[-1]] if k > 1 else idx[0]
        out.append((path.p_sheet_m[start, 0], path.p_sheet_m[idx[-1], 0]))
    return np.asarray(out)


def test_default_path_has_ten_passes_strokes_70_to_61_mm_and_depth_10_mm():
    spec = GrooveSpec()
    path = groove_path(spec)
    assert sorted(set(path.pass_index.tolist())) == list(range(1, 11))
    ends = _pass_ends(path, spec)
    strokes_mm = np.abs(ends[:, 1] - ends[:, 0]) * 1e3
    np.testing.assert_allclose(strokes_mm, np.arange(70, 60, -1), atol=1e-9)
    assert path.p_sheet_m[-1, 2] == pytest.approx(-0.010, abs=1e-12)
    assert path.p_sheet_m[:, 2].min() == pytest.approx(-0.010, abs=1e-12)
    np.testing.assert_array_equal(path.p_sheet_m[0], [-0.035, 0.0, 0.0])
    assert np.all(path.p_sheet_m[:, 1] == 0.0)


def test_end_walls_have_the_thesis_wall_angle_63_43_deg():
    spec = GrooveSpec()
    assert math.degrees(spec.wall_angle_rad) == pytest.approx(63.4349, abs=1e-4)
    path = groove_path(spec)
    ends = _pass_ends(path, spec)
    for side in (0, 1):  # pass ends on the right (odd passes) and on the left (even passes)
        x_end = np.abs(ends[side::2, 1])
        z_end = -np.arange(side + 1, 11, 2) * spec.step_down_m
        slope = np.diff(z_end) / np.diff(x_end)
        np.testing.assert_allclose(np.degrees(np.arctan(slope)), 63.4349, atol=1e-3)


def test_passes_alternate_direction_and_samples_move_that_way():
    path = groove_path()
    for k in range(1, 11):
        idx = np.flatnonzero(path.pass_index == k)
        assert np.all(path.direction[idx] == (1 if k % 2 else -1))
        steps = np.diff(path.p_sheet_m[np.r_[idx[0] - 1 if k > 1 else idx[0], idx], 0])
        assert np.all(np.sign(steps[steps != 0]) == path.direction[idx[0]])


def test_feed_is_constant_and_time_starts_at_zero():
    spec = GrooveSpec()
    path = groove_path(spec)
    speed = np.linalg.norm(np.diff(path.p_sheet_m, axis=0), axis=1) / np.diff(path.t_s)
    np.testing.assert_allclose(speed, spec.feed_m_per_s, rtol=1e-9)
    assert path.t_s[0] == 0.0
    assert np.diff(path.s_m).max() <= spec.spacing_m + 1e-12


def test_label_passes_reproduces_groove_path_labels():
    path = groove_path()
    pass_index, direction = label_passes(path.p_sheet_m[:, 0])
    np.testing.assert_array_equal(pass_index, path.pass_index)
    np.testing.assert_array_equal(direction, path.direction)


def test_label_passes_ignores_jitter_inside_the_dead_band():
    path = groove_path()
    x = path.p_sheet_m[:, 0] + 2e-6 * np.sin(np.arange(len(path)) * 1.7)
    pass_index, _ = label_passes(x, deadband_m=1e-4)
    assert pass_index.max() == 10
    assert np.mean(pass_index == path.pass_index) > 0.99


def test_label_passes_of_a_still_tool_is_one_pass_forward():
    pass_index, direction = label_passes(np.zeros(5))
    assert pass_index.tolist() == [1] * 5 and direction.tolist() == [1] * 5


def test_resample_gives_equal_arc_length_spacing():
    path = groove_path()
    r = resample_by_arc_length(path, 1311)
    assert len(r) == 1311
    np.testing.assert_allclose(r.p_sheet_m[[0, -1]], path.p_sheet_m[[0, -1]], atol=1e-15)
    with pytest.raises(InputError):
        resample_by_arc_length(path, 1)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"passes": 1},
        {"bottom_length_m": 0.080},
        {"depth_m": -0.01},
        {"feed_m_per_s": float("nan")},
        {"spacing_m": 0.0},
    ],
)
def test_groove_spec_rejects_bad_values(kwargs):
    with pytest.raises(InputError):
        GrooveSpec(**kwargs)


def test_write_path_csv_round_trips_in_millimetres(tmp_path):
    path = groove_path()
    out = write_path_csv(path, tmp_path / "path.csv")
    table = read_table(out, ("t_s", "x_mm", "y_mm", "z_mm", "pass", "direction"))
    np.testing.assert_allclose(table["x_mm"], path.p_sheet_m[:, 0] * 1e3, atol=5e-5)  # 0.1 µm, the path CSV precision
    np.testing.assert_allclose(table["z_mm"], path.p_sheet_m[:, 2] * 1e3, atol=5e-5)  # 0.1 µm, the path CSV precision
    np.testing.assert_array_equal(table["pass"], path.pass_index)


def test_path_command_writes_the_csv(tmp_path, capsys):
    assert main(["path", "--out", str(tmp_path / "p.csv"), "--passes", "4", "--bottom-length-mm", "64"]) == 0
    assert "wall angle" in capsys.readouterr().out
    assert read_table(tmp_path / "p.csv", ("pass",))["pass"].max() == 4


@settings(max_examples=15, deadline=None)
@given(
    passes=st.integers(2, 14),
    top_mm=st.floats(20.0, 150.0),
    bottom_frac=st.floats(0.5, 0.95),
    depth_mm=st.floats(1.0, 25.0),
)
def test_path_properties_hold_for_other_grooves(passes, top_mm, bottom_frac, depth_mm):
    spec = GrooveSpec(
        top_length_m=top_mm / 1e3,
        bottom_length_m=top_mm * bottom_frac / 1e3,
        depth_m=depth_mm / 1e3,
        passes=passes,
    )
    path = groove_path(spec)
    assert path.pass_index.max() == passes
    assert path.p_sheet_m[-1, 2] == pytest.approx(-spec.depth_m, abs=1e-12)
    ends = _pass_ends(path, spec)
    strokes = np.abs(ends[:, 1] - ends[:, 0])
    np.testing.assert_allclose(strokes, [spec.stroke_m(k) for k in range(1, passes + 1)], atol=1e-12)
    assert strokes[-1] == pytest.approx(spec.bottom_length_m, abs=1e-12)
    assert math.tan(spec.wall_angle_rad) == pytest.approx(2 * spec.depth_m / (passes * spec.rpp_m))
    pass_index, direction = label_passes(path.p_sheet_m[:, 0])
    np.testing.assert_array_equal(pass_index, path.pass_index)
    np.testing.assert_array_equal(direction, path.direction)
    assert np.all(np.diff(path.t_s) > 0)
