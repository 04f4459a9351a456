"""Is a design or a scan the part a tool path forms? One rule, used by every reader that puts them together.

A design (`compensate --target-stl`, `identify --springback --design`, `check --target-stl`) or a scan of the formed
part (`check --scan`, a run's `part_scan.csv`) used with a path of another part gives numbers that look like a
result: a compensation to the wrong surface, a springback fitted to the wrong part, a part "checked" against the
wrong design. `check_same_part` refuses them by comparing three things in the sheet frame, each with a tolerance
that a real part of the same path stays well inside:

* depth: the surface's deepest point against the path's. A formed part is shallower than its path by springback and
  the robot's compliance (about 1 mm on the thesis's 10 mm groove; up to 40 % of a 2 mm deep part; the twin's
  command for a 5 mm deep AA5086 cone goes 7.2 mm deep, and a sheet 20 % stronger forms it 4.6 mm deep, its
  wall turning back on release): refused beyond
  `DEPTH_TOLERANCE` of the path's depth or `DEPTH_TOLERANCE_M`, whichever is larger.
* outline and shape, at the depth `OUTLINE_DEPTH` x the path's depth: the support function h(theta) of the region
  deeper than that (its extent in each of `DIRECTIONS` directions of the x-y plane) against the path's. The same
  part's surface is the path's region dilated by the tool's envelope, so h_surface - h_path is about the same in
  every direction (measured: 0.5-2.5 mm of spread for cones, pyramids, the groove and their springback targets) and
  about the envelope's width (+2 to +11 mm for tool radii 7.5-25 mm). A pyramid for a cone of the same width
  differs by 41 % of the half-width along the diagonals (11 mm for a 60 mm part); a part of another size by the
  difference of their widths in every direction.
  - shape: the spread (largest minus smallest difference over the directions) must stay within
    `SHAPE_TOLERANCE` of the path's mean half-width or `SHAPE_TOLERANCE_M`, whichever is larger;
  - size: the median difference must lie within [-margin, tool radius + margin], margin `SHAPE_TOLERANCE` of the
    half-width or `SHAPE_TOLERANCE_M`.

A mesh is compared through its vertices below that depth and the points where its edges cross it (exact for a
coarse CAD mesh); a point cloud through its points, the third-largest extent in each direction (two stray points
change nothing). Nothing is compared when the path forms nothing (a flat path).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from twin.errors import InputError

#: The outline is compared at this fraction of the path's depth below the sheet (clear of a sagging flat sheet).
OUTLINE_DEPTH = 0.2
#: Directions of the x-y plane the outlines are compared in (every 5 degrees).
DIRECTIONS = 72
#: Depth: the surface's depth may differ from the path's by this fraction of it, or `DEPTH_TOLERANCE_M`.
DEPTH_TOLERANCE = 0.4
DEPTH_TOLERANCE_M = 2e-3
#: Outline: spread and size margin, this fraction of the path's mean half-width, or `SHAPE_TOLERANCE_M`.
SHAPE_TOLERANCE = 0.15
SHAPE_TOLERANCE_M = 4e-3
#: The tool radius assumed when the caller gives none (the thesis's Ø 15 mm tool) [m].
DEFAULT_TOOL_RADIUS_M = 7.5e-3
#: A point cloud's extent in a direction: its k-th largest projection (robust to k - 1 stray points).
CLOUD_RANK = 3


@dataclass(frozen=True)
class PartMatch:
    """How a surface compares with a path (module docstring), lengths [m].

    Attributes:
        path_depth_m: The path's depth below the sheet.
        surface_depth_m: The surface's.
        outline_depth_m: The depth the outlines are compared at.
        offset_m: Median over the directions of the surface's extent minus the path's.
        spread_m: Largest minus smallest of those differences.
        half_width_m: The path's mean half-width at that depth.
        problems: What does not match, in words; empty when it is the same part.
    """

    path_depth_m: float
    surface_depth_m: float
    outline_depth_m: float
    offset_m: float
    spread_m: float
    half_width_m: float
    problems: tuple[str, ...]


def compare_part(path_xyz_m: np.ndarray, surface: Any, *, tool_radius_m: float = DEFAULT_TOOL_RADIUS_M) -> PartMatch | None:
    """Compare a surface (an (m, 3) point array or a mesh with `vertices` and `edges_unique`) with a tool path
    (n, 3), both in the sheet frame [m]; None when the path forms nothing. `check_same_part` raises on a mismatch."""
    path = np.asarray(path_xyz_m, dtype=float).reshape(-1, 3)
    path_depth = float(-path[:, 2].min()) if len(path) else 0.0
    if not path_depth > 0.0:
        return None
    level = OUTLINE_DEPTH * path_depth
    mesh = hasattr(surface, "vertices") and hasattr(surface, "edges_unique")
    vertices = np.asarray(surface.vertices if mesh else surface, dtype=float).reshape(-1, 3)
    vertices = vertices[np.all(np.isfinite(vertices), axis=1)]
    surface_depth = float(-vertices[:, 2].min()) if len(vertices) else 0.0
    tolerance = max(DEPTH_TOLERANCE * path_depth, DEPTH_TOLERANCE_M)
    problems = []
    if abs(surface_depth - path_depth) > tolerance:
        problems.append(f"it is {1e3 * surface_depth:.1f} mm deep where the path goes {1e3 * path_depth:.1f} mm deep "
                        f"(accepted: within {1e3 * tolerance:.1f} mm)")
    edges = np.asarray(surface.edges_unique) if mesh else None
    region = _below(vertices, edges, level)
    if len(region) == 0:
        problems.append(f"nothing of it lies {1e3 * level:.1f} mm below the sheet, where the path forms a part "
                        f"{1e3 * path_depth:.1f} mm deep")
        return PartMatch(path_depth, surface_depth, level, float("nan"), float("nan"), float("nan"), tuple(problems))
    path_region = _below(path, np.column_stack([np.arange(len(path) - 1), np.arange(1, len(path))]), level)
    angles = np.linspace(0.0, 2.0 * np.pi, DIRECTIONS, endpoint=False)
    axes = np.column_stack([np.cos(angles), np.sin(angles)])
    h_path = _extent(path_region, axes, 1)
    h_surface = _extent(region, axes, 1 if mesh else CLOUD_RANK)
    difference = h_surface - h_path
    half_width = float(np.mean(h_path + np.roll(h_path, DIRECTIONS // 2)) / 2.0)
    margin = max(SHAPE_TOLERANCE * half_width, SHAPE_TOLERANCE_M)
    offset, spread = float(np.median(difference)), float(np.ptp(difference))
    if spread > margin:
        worst = int(np.argmax(np.abs(difference - offset)))
        problems.append(f"its outline {1e3 * level:.1f} mm below the sheet has another shape than the path's: their "
                        f"extents differ by {1e3 * spread:.1f} mm more in some directions than in others (e.g. "
                        f"{1e3 * difference[worst]:+.1f} mm toward {np.degrees(angles[worst]):.0f} deg against "
                        f"{1e3 * offset:+.1f} mm typically; accepted: {1e3 * margin:.1f} mm)")
    if not -margin <= offset <= tool_radius_m + margin:
        problems.append(f"its outline {1e3 * level:.1f} mm below the sheet lies {1e3 * offset:+.1f} mm outside the "
                        f"path's (accepted: {-1e3 * margin:+.1f} to {1e3 * (tool_radius_m + margin):+.1f} mm, the tool's "
                        f"envelope); footprint {_size(region)} against the path's {_size(path_region)}")
    return PartMatch(path_depth, surface_depth, level, offset, spread, half_width, tuple(problems))


def check_same_part(
    path_xyz_m: np.ndarray,
    surface: Any,
    what: str,
    *,
    path_what: str = "the tool path",
    tool_radius_m: float = DEFAULT_TOOL_RADIUS_M,
) -> PartMatch | None:
    """Refuse a design or scan that is not the part `path_xyz_m` forms (the rule and its tolerances: the module
    docstring).

    Args:
        path_xyz_m: The tool-tip path, sheet frame [m], shape (n, 3).
        surface: The design mesh (`read_target_mesh`, metres) or the scan's points, sheet frame [m], (m, 3) (a
            scanner's cloud after its registration).
        what: The surface as the user gave it, for the message (e.g. "--target-stl pyramid.stl").
        path_what: The path as the user gave it (e.g. "--ideal cone.csv").
        tool_radius_m: The tool's radius (how far a design's outline may lie outside the path's) [m].

    Returns:
        The comparison, or None when the path forms nothing (nothing to compare).

    Raises:
        InputError: The surface is not the path's part: names both, says what differs and what was accepted.
    """
    match = compare_part(path_xyz_m, surface, tool_radius_m=tool_radius_m)
    if match is not None and match.problems:
        raise InputError(f"{what} is not the part {path_what} forms: {'; '.join(match.problems)}; expected the design "
                         "or scan of this path's part (a file of another part?)")
    return match


def _below(points: np.ndarray, edges: np.ndarray | None, level: float) -> np.ndarray:
    """The x-y points of a surface's region deeper than `level`: its points there and, with edges (pairs of point
    indices), where its edges cross that depth."""
    deep = points[points[:, 2] < -level, :2]
    if edges is None or len(edges) == 0:
        return deep
    a, b = points[edges[:, 0]], points[edges[:, 1]]
    crossing = (a[:, 2] + level) * (b[:, 2] + level) < 0.0
    a, b = a[crossing], b[crossing]
    f = (-level - a[:, 2]) / (b[:, 2] - a[:, 2])
    return np.vstack([deep, a[:, :2] + f[:, None] * (b[:, :2] - a[:, :2])])


def _extent(points_xy: np.ndarray, axes: np.ndarray, rank: int) -> np.ndarray:
    """The `rank`-th largest projection of the points on each axis (the support function for rank 1), in chunks."""
    if len(points_xy) == 0:
        return np.full(len(axes), np.nan)
    rank = min(rank, len(points_xy))
    best = np.full((rank, len(axes)), -np.inf)
    for start in range(0, len(points_xy), 50_000):
        projected = np.vstack([best, points_xy[start:start + 50_000] @ axes.T])
        best = -np.partition(-projected, rank - 1, axis=0)[:rank]
    return np.asarray(np.min(best, axis=0))


def _size(points_xy: np.ndarray) -> str:
    """The x-y bounding box of points, in words [mm]."""
    if len(points_xy) == 0:
        return "empty"
    span = 1e3 * np.ptp(points_xy, axis=0)
    return f"{span[0]:.0f} x {span[1]:.0f} mm"
