"""The CAD-like check of a formed part: scan points against a target mesh (twin.analysis.surface_check)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from twin.analysis.surface_check import (
    DesignIndex,
    deviations,
    read_target_mesh,
    region_deviation,
    surface_deviation,
)
from twin.errors import DataFileError, InputError
from twin.process.part.bottom import with_floating_bottom
from twin.process.part.surface import heightmap_mesh, surface_points, target_part_surface
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.runs.format import Run, Stream
from twin.runs.read import read_run
from twin.runs.write import write_run


def _wedge(slope: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A V-shaped pit: z = -slope * (10 mm - |x|) inside |x| < 10 mm, flat outside, on a 0.5 mm grid."""
    x = np.arange(-0.03, 0.03 + 1e-12, 5e-4)
    y = np.arange(-0.02, 0.02 + 1e-12, 5e-4)
    z = -slope * np.clip(0.01 - np.abs(x), 0.0, None)
    return x, y, np.tile(z, (len(y), 1))


def test_a_surface_shifted_up_deviates_by_the_normal_distance_with_a_plus_sign():
    x, y, z = _wedge(slope=1.0)  # 45 degree walls
    target = heightmap_mesh(x, y, z)
    points = surface_points(x, y, z)
    lift = 0.2e-3
    result = surface_deviation(points + np.array([0.0, 0.0, lift]), target)
    walls = np.abs(np.abs(result.points_m[:, 0]) - 0.005) < 0.004  # away from the pit's bottom corner
    np.testing.assert_allclose(result.deviation_m[walls], lift * math.cos(math.radians(45.0)), rtol=1e-6)
    assert result.mean_m > 0.0  # too shallow
    below = surface_deviation(points - np.array([0.0, 0.0, lift]), target)
    assert below.mean_m < 0.0
    exact = surface_deviation(points, target)
    assert exact.max_abs_m < 1e-12
    # `check`'s one query for both is each of them
    index = DesignIndex(target)
    surface, regions = deviations(points + np.array([0.0, 0.0, lift]), index)
    alone = region_deviation(points + np.array([0.0, 0.0, lift]), index)
    np.testing.assert_array_equal(surface.deviation_m, result.deviation_m)
    np.testing.assert_array_equal(surface.points_m, result.points_m)
    np.testing.assert_array_equal(regions.deviation_m, alone.deviation_m)
    np.testing.assert_array_equal(regions.region, alone.region)


def test_only_the_formed_region_is_compared():
    x, y, z = _wedge()
    result = surface_deviation(surface_points(x, y, z), heightmap_mesh(x, y, z))
    assert np.all(np.abs(result.points_m[:, 0]) < 0.01)
    flat = np.column_stack([np.full(5, 0.025), np.linspace(-0.01, 0.01, 5), np.zeros(5)])
    with pytest.raises(InputError, match="formed region"):
        surface_deviation(flat, heightmap_mesh(x, y, z))


def test_target_mesh_is_read_in_millimetres_and_metres_are_refused(tmp_path: Path):
    x, y, z = _wedge()
    mesh = heightmap_mesh(x, y, z)
    metres = tmp_path / "metres.stl"
    metres.write_bytes(mesh.export(file_type="stl"))
    with pytest.raises(DataFileError, match="millimetres"):
        read_target_mesh(metres)
    mesh.apply_scale(1e3)
    mm = tmp_path / "mm.stl"
    mm.write_bytes(mesh.export(file_type="stl"))
    np.testing.assert_allclose(read_target_mesh(mm).bounds, heightmap_mesh(x, y, z).bounds, atol=1e-9)
    with pytest.raises(DataFileError, match="no such"):
        read_target_mesh(tmp_path / "missing.stl")
    (tmp_path / "junk.stl").write_text("not a mesh")
    with pytest.raises(DataFileError):
        read_target_mesh(tmp_path / "junk.stl")


def test_a_perfect_machines_cone_is_its_own_target_and_a_flat_sheet_has_no_scan():
    path = part_path(PartSpec(shape="cone", top_half_width_m=0.01, depth_m=0.002, step_down_m=5e-4))
    x, y, z = target_part_surface(path)
    assert z.min() < -1e-3  # 1.2 mm of the 2 mm: the sheet springs back (elastic recovery)
    result = surface_deviation(surface_points(x, y, z), heightmap_mesh(x, y, z))
    assert result.max_abs_m < 1e-12
    with pytest.raises(InputError, match="flat"):
        surface_points(x, y, np.zeros_like(z))


def test_part_scan_round_trips_through_the_run_format(tmp_path: Path):
    t = np.linspace(0.0, 2.0, 101)
    p = np.column_stack([np.linspace(-0.03, 0.03, 101), np.zeros(101), np.zeros(101)])
    scan = np.column_stack([np.linspace(-0.02, 0.02, 50), np.zeros(50), -np.linspace(0.0, 1e-3, 50)])
    meta = {"format": "tx200-twin-run/1", "frame": "sheet", "scenario": "nominal", "tool_length_m": 0.27494,
            "tracker_rate_hz": 50.0}
    run = Run(None, meta, Stream(t, p), Stream(t, p), None, None, scan)
    back = read_run(write_run(tmp_path / "run", run), require_forces=False)
    assert back.part_scan is not None
    np.testing.assert_allclose(back.part_scan, scan, atol=1e-6)
    with pytest.raises(InputError, match="part_scan"):
        Run(None, meta, Stream(t, p), Stream(t, p), None, None, scan[:, :2])


def _ring_part(turns: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A trench 2 mm deep along a circle of 10 mm radius (what a z-level contour forms), the tips that formed it."""
    x = np.arange(-0.02, 0.02 + 1e-12, 5e-4)
    X, Y = np.meshgrid(x, x)
    r = np.hypot(X, Y)
    z = np.where(np.abs(r - 0.01) < 0.003, -0.002, 0.0)
    phi = np.linspace(0.0, 2.0 * np.pi * turns, 400)
    track = np.column_stack([0.01 * np.cos(phi), 0.01 * np.sin(phi), np.full_like(phi, -0.002)])
    return x, x, z, track


def test_the_unsupported_bottom_inside_the_last_contour_hangs_at_its_depth():
    x, y, z, track = _ring_part(turns=1.2)
    out = with_floating_bottom(x, y, z, track, 5e-5)
    centre = (len(y) // 2, len(x) // 2)
    assert z[centre] == 0.0 and out[centre] == pytest.approx(-0.002)  # the plate moved down with the contour
    assert out[0, 0] == 0.0  # the sheet outside, held by the clamp, stays
    np.testing.assert_array_equal(out[z < 0.0], z[z < 0.0])  # the formed wall is unchanged
    # a trench that does not close holds nothing up, even where the track turns a full revolution: nothing moves
    x, y, z, track = _ring_part(turns=1.2)
    z_open = z.copy()
    z_open[:, : len(x) // 2] = 0.0  # an arc, not a ring: the inside is connected to the sheet outside
    np.testing.assert_array_equal(with_floating_bottom(x, y, z_open, track, 5e-5), z_open)
    # nor does a closed ring whose track never turns once about it (no last contour to hang from)
    half = track[: len(track) * 5 // 12]  # 0.5 of the 1.2 turns
    np.testing.assert_array_equal(with_floating_bottom(x, y, z, half, 5e-5), z)


def test_a_cones_target_has_its_bottom_at_the_last_contours_depth():
    path = part_path(PartSpec(shape="cone", top_half_width_m=0.02, depth_m=0.005))
    x, y, z = target_part_surface(path)
    centre = z[np.argmin(np.abs(y)), np.argmin(np.abs(x))]
    wall_bottom = z[np.argmin(np.abs(y)), np.argmin(np.abs(x - 0.015))]  # under the last contour (45°: 20 - 5)
    assert centre < -0.6 * 0.005  # not at the flat sheet's height: the plate went down with the tool
    assert centre == pytest.approx(wall_bottom, abs=3e-4)
