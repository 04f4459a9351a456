"""Tests of the ISF test-part paths (twin/process/toolpath/shapes.py), the placement and reach check
(twin/process/toolpath/placement.py) and `tx200-twin path --shape/--gcode`."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twin.base.csvio import read_table
from twin.cli import main
from twin.errors import InputError, UnreachableError
from twin.process.toolpath.placement import Placement, check_reach
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.robot.kinematics import Kinematics

SMALL = {"top_half_width_m": 0.03, "depth_m": 0.01, "step_down_m": 1e-3, "spacing_m": 1e-3}


@pytest.fixture(scope="module")
def kin() -> Kinematics:
    return Kinematics()


@pytest.mark.parametrize("mode", ["spiral", "z-level"])
@pytest.mark.parametrize("angle", [30.0, 45.0, 60.0])
def test_cone_tool_tip_lies_on_a_cone_of_the_wall_angle(mode, angle):
    spec = PartSpec(shape="cone", wall_angle_deg=angle, mode=mode, **SMALL)
    p = part_path(spec).p_sheet_m
    r = np.hypot(p[:, 0], p[:, 1])
    contour = np.ones(len(p), bool) if mode == "spiral" else np.isclose(p[:, 2] % 1e-3, 0.0, atol=1e-12) | (
        np.isclose(p[:, 2] % 1e-3, 1e-3, atol=1e-12))
    expected = 0.03 + p[:, 2] / math.tan(math.radians(angle))
    np.testing.assert_allclose(r[contour], expected[contour], atol=1e-12)
    assert p[0] == pytest.approx([0.03, 0.0, 0.0])
    assert p[-1, 2] == pytest.approx(-0.01, abs=1e-12)


@pytest.mark.parametrize("shape", ["cone", "pyramid", "vwa-cone"])
@pytest.mark.parametrize("mode", ["spiral", "z-level"])
def test_parts_have_n_passes_spacing_bound_constant_feed_and_monotone_depth(shape, mode):
    spec = PartSpec(shape=shape, mode=mode, **SMALL)
    path = part_path(spec)
    steps = np.linalg.norm(np.diff(path.p_sheet_m, axis=0), axis=1)
    assert steps.max() <= spec.spacing_m + 1e-12 and steps.min() > 0
    assert sorted(set(path.pass_index.tolist())) == list(range(1, 11))
    assert np.all(np.diff(path.pass_index) >= 0)
    assert np.all(np.diff(path.p_sheet_m[:, 2]) <= 1e-15)  # never climbs
    np.testing.assert_allclose(steps / np.diff(path.t_s), spec.feed_m_per_s, rtol=1e-9)


def test_z_level_contours_are_flat_and_closed():
    path = part_path(PartSpec(shape="cone", mode="z-level", **SMALL))
    for k in range(1, 11):
        level = path.p_sheet_m[(path.pass_index == k) & np.isclose(path.p_sheet_m[:, 2], -k * 1e-3, atol=1e-12)]
        assert len(level) > 100
        assert level[0] == pytest.approx(level[-1], abs=1e-12)  # closed: ends where it began


def test_pyramid_contours_are_squares_with_corners_sampled():
    path = part_path(PartSpec(shape="pyramid", mode="z-level", **SMALL))
    level = path.p_sheet_m[np.isclose(path.p_sheet_m[:, 2], -5e-3, atol=1e-12)]
    half = 0.03 - 5e-3  # 45 deg
    assert np.max(np.abs(level[:, :2]), axis=1) == pytest.approx(np.full(len(level), half), abs=1e-12)
    for corner in ([half, half], [-half, half], [-half, -half], [half, -half]):
        assert np.min(np.linalg.norm(level[:, :2] - corner, axis=1)) < 1e-12


def test_variable_wall_angle_cone_slope_follows_the_angle_law():
    spec = PartSpec(shape="vwa-cone", wall_angle_deg=40.0, wall_angle_end_deg=70.0, **SMALL)
    d = np.linspace(0.0, spec.depth_m, 201)
    w = spec.half_width_m(d)
    slope = -np.gradient(w, d)  # dw/dd = -cot alpha
    alpha = np.radians(40.0 + 30.0 * d / spec.depth_m)
    np.testing.assert_allclose(slope[1:-1], 1.0 / np.tan(alpha[1:-1]), rtol=1e-3)


def test_step_down_is_an_upper_bound_with_equal_levels():
    spec = PartSpec(shape="cone", depth_m=0.01, step_down_m=0.3e-3, top_half_width_m=0.03)
    assert spec.levels == 34
    assert spec.depth_m / spec.levels <= spec.step_down_m


@pytest.mark.parametrize(
    "kwargs",
    [
        {"shape": "sphere"},
        {"mode": "helix"},
        {"wall_angle_deg": 90.0},
        {"depth_m": -0.01},
        {"top_half_width_m": 0.02, "depth_m": 0.04},  # 45 deg: closes 20 mm down
        {"shape": "vwa-cone", "wall_angle_end_deg": 45.0},
    ],
)
def test_part_spec_rejects_bad_values(kwargs):
    with pytest.raises(InputError):
        PartSpec(**kwargs)


def test_placement_moves_and_turns_the_sheet_frame(kin):
    p = np.array([[0.01, 0.0, 0.0], [0.0, 0.02, -0.001]])
    base = Placement(origin_base_m=(1.0, 0.5, 0.3), yaw_rad=math.pi / 2).to_base(p, kin)
    np.testing.assert_allclose(base, [[1.0, 0.51, 0.3], [0.98, 0.5, 0.299]], atol=1e-15)
    np.testing.assert_allclose(Placement().to_base(p, kin)[0], kin.p_base_sheet_origin + p[0])


def test_cone_is_reachable_at_the_default_placement_with_margins(kin):
    path = part_path(PartSpec(shape="cone", spacing_m=2e-3, step_down_m=4e-3))
    report = check_reach(path, kinematics=kin)
    assert report.q_rad.shape == (len(path), 6)
    assert report.min_abs_det_j > kin.det_j_min
    assert np.all(report.joint_margin_rad > 0)
    np.testing.assert_allclose(kin.fk(report.q_rad[-1])[0], Placement().to_base(path.p_sheet_m, kin)[-1], atol=1e-9)


def test_reach_error_names_the_first_sample_out_of_reach(kin):
    path = part_path(PartSpec(shape="cone", spacing_m=2e-3, step_down_m=4e-3))
    origin = kin.p_base_sheet_origin.copy()
    # far enough out that the outer half of the cone (x > 0 in the sheet frame) is beyond the TX200's reach
    for dx in (0.5, 0.6, 0.7, 0.8):
        placement = Placement(origin_base_m=tuple(origin + np.array([dx, 0.0, 0.0])))
        try:
            check_reach(path, placement, kinematics=kin)
        except UnreachableError as exc:
            assert "path sample 0 of" in str(exc) and "sheet-frame position" in str(exc)
            return
    pytest.fail("no placement out to +0.8 m made the cone unreachable")


def test_path_command_writes_a_cone_and_its_gcode_and_reimports_it(tmp_path, capsys):
    out, nc = tmp_path / "cone.csv", tmp_path / "cone.nc"
    argv = ["path", "--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10", "--step-down-mm", "2",
            "--spacing-mm", "2", "--out", str(out), "--gcode-out", str(nc)]
    assert main(argv) == 0
    assert "reachable" in capsys.readouterr().out
    table = read_table(out, ("t_s", "x_mm", "z_mm", "pass"))
    assert table["pass"].max() == 5 and table["z_mm"].min() == pytest.approx(-10.0, abs=1e-5)
    assert main(["path", "--gcode", str(nc), "--out", str(tmp_path / "back.csv"), "--no-reach-check",
                 "--spacing-mm", "2.5"]) == 0  # its 2 mm steps kept as they are
    back = read_table(tmp_path / "back.csv", ("t_s", "x_mm", "z_mm"))
    np.testing.assert_allclose(back["x_mm"], table["x_mm"], atol=1e-4)
    np.testing.assert_allclose(back["t_s"], table["t_s"], rtol=1e-4, atol=1e-3)


def test_path_command_reports_an_unreachable_placement(tmp_path, capsys):
    argv = ["path", "--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10", "--step-down-mm", "5",
            "--spacing-mm", "5", "--origin-mm", "4000", "0", "400", "--out", str(tmp_path / "c.csv")]
    assert main(argv) == 2
    assert "path sample 0" in capsys.readouterr().err
    assert not (tmp_path / "c.csv").exists()
