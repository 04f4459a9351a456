"""Tests of the G-code import/export (twin/process/toolpath/gcode.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twin.errors import DataFileError, InputError
from twin.process.toolpath.gcode import parse_gcode, read_gcode
from twin.process.toolpath.gcode_write import write_gcode
from twin.process.toolpath.shapes import PartSpec, part_path


def test_linear_moves_absolute_and_incremental_in_mm_and_inches():
    text = "%\nN10 G21 G90 (mm, absolute)\nG0 X10 Y0 Z5\nG1 Z0 F600 ; 10 mm/s\nX20\nG91 Y5\nG20 G1 Z-0.1\nM30\n"
    path = parse_gcode(text, spacing_m=0.1)  # steps up to 100 mm: every line one step
    expected_mm = [[10, 0, 5], [10, 0, 0], [20, 0, 0], [20, 5, 0], [20, 5, -2.54]]
    np.testing.assert_allclose(path.p_sheet_m * 1e3, expected_mm, atol=1e-12)
    # G1 at F600 mm/min = 10 mm/s; in G20 the modal F600 stays 10 mm/s (F is converted when it is set)
    np.testing.assert_allclose(np.diff(path.t_s), [0.5, 1.0, 0.5, 0.254], rtol=1e-12)
    assert path.t_s[0] == 0.0


def test_a_long_line_is_divided_into_steps_no_longer_than_the_spacing_at_the_feed():
    """A CAM program's 20 mm G1 line: the twin forms the sheet at the samples, so the line is sampled as the
    controller runs it (the first move's start is unknown: it stays one step)."""
    path = parse_gcode("G21 G90\nG1 X10 Y-15 Z-1 F600\nG1 X-10\n", spacing_m=0.5e-3)
    p = path.p_sheet_m * 1e3
    assert len(p) == 41
    np.testing.assert_allclose(p[:, 0], np.linspace(10.0, -10.0, 41), atol=1e-12)
    np.testing.assert_allclose(p[:, 1:], np.tile([-15.0, -1.0], (41, 1)), atol=1e-12)
    np.testing.assert_allclose(np.diff(path.t_s), 0.05, rtol=1e-12)  # 0.5 mm at 10 mm/s
    assert len(parse_gcode("G1 X3 Y4 Z0 F600\nG1 X3 Y4 Z-1\n")) == 3  # 1 mm down in two 0.5 mm steps


def test_g20_feed_is_in_inches_per_minute():
    path = parse_gcode("G20 G90\nG1 X0 Y0 Z0 F60\nG1 X1\n")
    assert path.t_s[-1] == pytest.approx(1.0)  # 1 inch at 60 in/min
    assert path.p_sheet_m[-1, 0] == pytest.approx(0.0254)


@pytest.mark.parametrize("centre", ["I-10 J0", "R10"])
def test_counter_clockwise_half_circle_is_linearised_on_the_circle(centre):
    path = parse_gcode(f"G21 G90\nG1 X10 Y0 Z0 F600\nG3 X-10 Y0 Z-1 {centre}\n", spacing_m=0.5e-3, chord_tol_m=1e-6)
    p = path.p_sheet_m * 1e3
    np.testing.assert_allclose(np.hypot(p[:, 0], p[:, 1]), 10.0, atol=1e-9)
    assert np.all(p[1:, 1] >= -1e-12) and p[:, 1].max() == pytest.approx(10.0, abs=1e-3)  # over +y
    np.testing.assert_allclose(p[-1], [-10, 0, -1], atol=1e-12)
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    assert steps.max() <= 0.5 + 1e-9
    # helical: z falls linearly with the swept angle; the time is the arc length at 10 mm/s
    assert path.t_s[-1] == pytest.approx(math.hypot(math.pi * 10.0, 1.0) / 10.0, rel=1e-3)


def test_clockwise_full_circle_from_ij_and_chord_tolerance():
    path = parse_gcode("G21\nG1 X5 Y0 Z0 F300\nG2 X5 Y0 I-5 J0\n", spacing_m=10e-3, chord_tol_m=1e-5)
    p = path.p_sheet_m * 1e3
    assert p[1, 1] < 0  # clockwise from (5, 0) goes down in y first
    mid = 0.5 * (p[1:] + p[:-1])
    assert 5.0 - np.hypot(mid[:, 0], mid[:, 1]).min() <= 1e-2 + 1e-9  # chord sag <= 10 µm
    np.testing.assert_allclose(p[-1], [5, 0, 0], atol=1e-12)


@pytest.mark.parametrize(
    ("text", "line", "what"),
    [
        ("G21\nG1 X1 Y1 Z0\n", 2, "feed"),
        ("G21 F100\nG1 X1\nG18 G2 X2 I1\n", 3, "G18"),
        ("G21 F100\nG1 X1\nG41 X3\n", 3, "G41"),
        ("G1 X1 F100\nG1 X2 Q5\n", 2, "Q5"),
        ("G1 X1 F100\nG1 X2 Y$\n", 2, "$"),
        ("G1 X0 Y0 F100\nG2 X10 Y0\n", 2, "I/J"),
        ("G1 X0 Y0 F100\nG2 X10 Y0 R2\n", 2, "R2"),
        ("G1 X0 Y0 F100\nG2 X10 Y0 I3 J0\n", 2, "radii"),
        ("G1 X0 F-5\n", 1, "F-5"),
        ("X5 Y5\n", 1, "motion mode"),
    ],
)
def test_bad_gcode_names_the_file_and_line(tmp_path, text, line, what):
    file = tmp_path / "bad.nc"
    file.write_text(text)
    with pytest.raises(DataFileError) as info:
        read_gcode(file)
    message = str(info.value)
    assert str(file) in message and f"line {line}:" in message and what in message


def test_missing_file_and_bad_options_are_refused(tmp_path):
    with pytest.raises(DataFileError, match="file not found; expected a G-code program"):
        read_gcode(tmp_path / "absent.nc")
    with pytest.raises(InputError, match="spacing_m"):
        parse_gcode("G1 X1 F1\nG1 X2\n", spacing_m=0.0)
    with pytest.raises(DataFileError, match="at least 2 moves"):
        parse_gcode("G1 X1 F1\n")


def test_dwell_adds_time_and_zero_length_moves_add_no_sample():
    path = parse_gcode("G1 X0 Y0 Z0 F600\nG4 P2.5\nG1 X10\nG1 X10\n", spacing_m=0.02)
    assert len(path) == 3
    np.testing.assert_allclose(path.t_s, [0.0, 2.5, 3.5])


def test_write_then_read_round_trips_a_spiral_pyramid(tmp_path):
    path = part_path(PartSpec(shape="pyramid", top_half_width_m=0.03, depth_m=0.01, step_down_m=1e-3, spacing_m=1e-3))
    back = read_gcode(write_gcode(path, tmp_path / "pyr.nc"), spacing_m=2e-3)  # its 1 mm steps kept
    np.testing.assert_allclose(back.p_sheet_m, path.p_sheet_m, atol=5.1e-8)  # 4 decimals of a millimetre
    np.testing.assert_allclose(back.t_s, path.t_s, rtol=1e-4)
