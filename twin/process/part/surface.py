"""The formed part as a surface: a perfect machine's target part, a scan of a formed one, and their meshes.

A forming lab checks a part the way a CAD check does: the part is scanned (a point cloud of its upper surface
after unclamping, e.g. a fringe-projection scanner) and compared with the target geometry (an STL). Here:

* `target_part_surface(path)`: the part a rigid machine forms along the ideal path, after elastic recovery:
  the height-map ISF model (`twin.process.force.isf`) driven along the path without deflection. It is the
  target for a check of the *forming*, as the ideal path is for the tool path.
* `design_part_surface(path)`: the part as CAD gives it: the sheet's tool-side surface a rigid machine forms
  along the path with no springback, the lower envelope of the tool sphere (`twin.process.part.heightmap`) with the
  unsupported bottom lowered (`twin.process.part.bottom`). The reference of a check of a scanned part.
* `formed_surface(field)`: the surface a force field with a height map (`IsfForceField`) has formed, after
  the tool has left, its unsupported bottom lowered with the last contour (`twin.process.part.bottom`); None for
  a field without one (the groove's table field keeps a centre line only).
* `springback_surface(field, recovery_scale, depth_ratio)`: the same with the springback's two constants given
  (`formed_surface` takes them from the field's `IsfForceParams`; `identify --springback` fits them to a scan);
  the wall's tilt when the load is released (`twin.process.part.wall_tilt`) is the model's, with the params'
  material and `wall_tilt_scale`.
* `surface_points(...)`: grid nodes of a surface over the formed region and a margin, every `spacing_m`:
  what a scan gives (the labs add their own scanner noise).
* `heightmap_mesh(...)`: a triangulated surface (`trimesh.Trimesh`), e.g. to write the target as an STL.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import trimesh

from twin.errors import InputError
from twin.process.force.isf import IsfForceField
from twin.process.force.isf_params import IsfForceParams
from twin.process.part.bottom import with_floating_bottom
from twin.process.part.heightmap import HeightMap
from twin.process.part.wall_tilt import Sheet, tilt_lift_m
from twin.process.toolpath.groove import ToolPath

SCAN_SPACING_M = 1e-3  # a scan's point spacing [m]
FORMED_BELOW_M = 5e-5  # a node counts as formed when it lies this far below the flat sheet [m]
SCAN_MARGIN_M = 5e-3  # the scan covers the formed region and this margin of flat sheet [m]
DESIGN_MARGIN_M = 10e-3  # a design mesh keeps this much flat sheet around the part (the registration's datum) [m]


def formed_surface(field: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The surface a field has formed, after the tool has left: (x_m (nx,), y_m (ny,), z_m (ny, nx)) [m].

    Args:
        field: A sheet force field; one with a height map (`map`, `k_unload`) gives its unloaded surface.

    Returns:
        The grid and heights, or None when the field keeps no 2-D surface (the groove's table field).
    """
    height_map = getattr(field, "map", None)
    if height_map is None or not hasattr(field, "k_unload"):
        return None
    params = getattr(field, "params", None)
    return springback_surface(field, getattr(params, "recovery_scale", 1.0), getattr(params, "depth_ratio", 1.0))


def springback_surface(
    field: Any, recovery_scale: float = 1.0, depth_ratio: float = 1.0, tilt_scale: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The surface a height-map field has formed, after unclamping, with given springback constants [m]:

        z_after = depth_ratio · min(min(z_loaded + recovery_scale · F_z/k_unload, 0) + tilt_scale · lift, 0)

    (the unsupported bottom hanging from the last contour before the tilt and the depth ratio apply; lift the
    wall's tilt, `twin.process.part.wall_tilt`, with the field's params' sheet).

    Args:
        field: A sheet force field with a height map (`map`, `k_unload`).
        recovery_scale: Factor on the elastic recovery F_z/k_unload [-] (> 0).
        depth_ratio: Depth after unclamping over the depth with that recovery [-] (> 0).
        tilt_scale: Factor on the wall's tilt [-] (>= 0); None: the field's params' `wall_tilt_scale`.
    """
    if not (recovery_scale > 0 and depth_ratio > 0 and (tilt_scale is None or tilt_scale >= 0)):
        raise InputError(f"recovery_scale {recovery_scale!r}, depth_ratio {depth_ratio!r} and tilt_scale "
                         f"{tilt_scale!r}: expected numbers > 0 (the tilt's >= 0)")
    height_map = field.map
    x, y = np.asarray(height_map.x_m, dtype=float), np.asarray(height_map.y_m, dtype=float)
    z = height_map.unloaded_z_m(field.k_unload / recovery_scale)
    if len(height_map.track_m) >= 3:  # the unsupported bottom inside the last contour moves down with it
        z = with_floating_bottom(x, y, z, height_map.track_m, FORMED_BELOW_M)
    params = getattr(field, "params", None)
    scale = (0.0 if params is None else params.wall_tilt_scale) if tilt_scale is None else tilt_scale
    if params is not None and scale > 0:
        z = np.minimum(z + scale * _tilt_lift(field, params), 0.0)
    return x, y, depth_ratio * z


def _tilt_lift(field: Any, params: IsfForceParams) -> np.ndarray:
    """The wall's tilt lift of a field's part [m] (`twin.process.part.wall_tilt.tilt_lift_m`), read off its loaded
    surface with its floating bottom: the part's shape, not its recovery, so that a fit of the recovery and the
    depth ratio (`identify --springback`) moves nothing else. Kept on the field until it forms more."""
    height_map = field.map
    key = (len(height_map.track_m), params)
    cached = getattr(field, "_tilt_lift_cache", None)
    if cached is not None and cached[0] == key:
        return cached[1]
    x, y = np.asarray(height_map.x_m, dtype=float), np.asarray(height_map.y_m, dtype=float)
    loaded = height_map.z_loaded_m
    if len(height_map.track_m) >= 3:
        loaded = with_floating_bottom(x, y, loaded, height_map.track_m, FORMED_BELOW_M)
    lift = tilt_lift_m(x, y, loaded, height_map.track_m, sheet_of(params), FORMED_BELOW_M)
    field._tilt_lift_cache = (key, lift)
    return lift


def sheet_of(params: IsfForceParams) -> Sheet:
    """What the wall's tilt needs of the params' sheet and tool (`twin.process.part.wall_tilt.Sheet`)."""
    return Sheet(params.thickness_m, params.tool_radius_m, 1e9 * params.youngs_modulus_gpa, params.poisson_ratio,
                 1e6 * params.hardening_k_mpa, params.hardening_n)


def target_part_surface(
    path: ToolPath, params: IsfForceParams | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The part a rigid machine forms along `path`, after elastic recovery (x_m, y_m, z_m grid) [m].

    Args:
        path: The ideal tool-tip path, sheet frame.
        params: ISF model constants (tool radius, grid, springback); None for the calibrated defaults.
    """
    field = IsfForceField(params)
    field.rigid_forces(path)
    surface = formed_surface(field)
    assert surface is not None  # an IsfForceField always has a height map
    return surface


def design_part_surface(
    path: ToolPath, params: IsfForceParams | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The part as designed: the tool sphere's lower envelope along `path`, no springback (x_m, y_m, z_m) [m].

    The sheet's tool-side surface in the sheet frame (z = 0 at the unformed sheet's top), on a grid of the
    params' spacing that covers the path, the tool and `DESIGN_MARGIN_M`; the unsupported bottom inside the last
    contour hangs at that contour's depth, as in `formed_surface`.

    Args:
        path: The ideal tool-tip path, sheet frame.
        params: ISF model constants (only the tool radius and the grid spacing count); None for the defaults.
    """
    p = params or IsfForceParams()
    reach = float(np.max(np.abs(path.p_sheet_m[:, :2]))) + p.tool_radius_m + DESIGN_MARGIN_M
    half = p.spacing_m * (np.ceil(reach / p.spacing_m) + 1.0)
    height_map = HeightMap(p.tool_radius_m, p.spacing_m, (half, half), lag_m=0.0)
    for tip in path.p_sheet_m:
        height_map.commit(tip)
    height_map.flush()
    x, y, z = height_map.x_m, height_map.y_m, height_map.z_met_m.copy()
    if len(path) >= 3:
        z = with_floating_bottom(x, y, z, height_map.track_m, FORMED_BELOW_M)
    return x, y, z


def _formed_window(
    x_m: np.ndarray, y_m: np.ndarray, z_m: np.ndarray, margin_m: float
) -> tuple[slice, slice]:
    """Row and column slices of the grid over the formed region and `margin_m` around it.

    Raises:
        InputError: Shapes disagree, or nothing is formed.
    """
    if np.shape(z_m) != (len(y_m), len(x_m)) or len(x_m) < 2 or len(y_m) < 2:
        raise InputError(
            f"surface grid: z {np.shape(z_m)} must be (len(y) {len(y_m)}, len(x) {len(x_m)}), both >= 2"
        )
    rows, cols = np.nonzero(np.asarray(z_m) < -FORMED_BELOW_M)
    if rows.size == 0:
        raise InputError(f"the surface is flat: no node lies {FORMED_BELOW_M * 1e3:g} mm below the sheet")
    pad = int(np.ceil(margin_m / float(x_m[1] - x_m[0])))
    return (
        slice(max(rows.min() - pad, 0), min(rows.max() + pad + 1, len(y_m))),
        slice(max(cols.min() - pad, 0), min(cols.max() + pad + 1, len(x_m))),
    )


def surface_points(
    x_m: np.ndarray,
    y_m: np.ndarray,
    z_m: np.ndarray,
    *,
    spacing_m: float = SCAN_SPACING_M,
    margin_m: float = SCAN_MARGIN_M,
) -> np.ndarray:
    """Grid nodes of a surface over its formed region and a margin, about every `spacing_m` [m], shape (n, 3).

    Args:
        x_m, y_m: Grid axes [m], (nx,), (ny,), uniform.
        z_m: Heights [m], (ny, nx).
        spacing_m: Point spacing (rounded to a whole number of grid steps) [m].
        margin_m: Flat sheet kept around the formed region [m].

    Raises:
        InputError: Shapes disagree, or nothing is formed.
    """
    rows, cols = _formed_window(x_m, y_m, z_m, margin_m)
    step = max(1, round(spacing_m / float(x_m[1] - x_m[0])))
    iy = np.arange(len(y_m))[rows][::step]
    ix = np.arange(len(x_m))[cols][::step]
    X, Y = np.meshgrid(np.asarray(x_m)[ix], np.asarray(y_m)[iy])
    return np.column_stack([X.ravel(), Y.ravel(), np.asarray(z_m, dtype=float)[np.ix_(iy, ix)].ravel()])


def heightmap_mesh(x_m: np.ndarray, y_m: np.ndarray, z_m: np.ndarray) -> trimesh.Trimesh:
    """The surface z(x, y) on a grid as a triangle mesh (two triangles per cell, normals up) [m].

    Args:
        x_m, y_m: Grid axes [m], (nx,), (ny,).
        z_m: Heights [m], (ny, nx).
    """
    z = np.asarray(z_m, dtype=float)
    nx, ny = len(x_m), len(y_m)
    if z.shape != (ny, nx) or nx < 2 or ny < 2:
        raise InputError(f"surface grid: z {z.shape} must be (len(y) {ny}, len(x) {nx}), both >= 2")
    X, Y = np.meshgrid(np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float))
    vertices = np.column_stack([X.ravel(), Y.ravel(), z.ravel()])
    index = np.arange(nx * ny).reshape(ny, nx)
    a, b = index[:-1, :-1].ravel(), index[:-1, 1:].ravel()
    c, d = index[1:, :-1].ravel(), index[1:, 1:].ravel()
    faces = np.vstack([np.column_stack([a, b, d]), np.column_stack([a, d, c])])  # counter-clockwise from above
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


def cropped_surface(
    x_m: np.ndarray, y_m: np.ndarray, z_m: np.ndarray, margin_m: float = SCAN_MARGIN_M
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The grid cut to the formed region and a margin (a smaller mesh for the same comparison)."""
    rows, cols = _formed_window(x_m, y_m, z_m, margin_m)
    return np.asarray(x_m)[cols], np.asarray(y_m)[rows], np.asarray(z_m, dtype=float)[rows, cols]
