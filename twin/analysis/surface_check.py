"""A CAD-like check of a formed part: the scanned surface against the target part's mesh.

Each scan point's deviation is its signed distance to the target mesh along the mesh's normal (the closest
point on the mesh, `trimesh.proximity.closest_point`): positive when the part lies above the target (formed
too shallow, the usual error of a compliant robot pushed back by the sheet), negative below. Only points over
the target's formed region count (the target at least `COMPARE_BELOW_M` below the flat sheet, and no closer
than `EDGE_M` to the mesh's border, where the closest point is the border and not the surface).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from twin.errors import DataFileError, InputError

COMPARE_BELOW_M = 1e-4  # the part is compared where the target lies this far below the flat sheet [m]
EDGE_M = 1e-3  # scan points this close to the target mesh's border (in x, y) are not compared [m]


@dataclass(frozen=True)
class SurfaceDeviation:
    """Deviation of a scanned part from its target.

    Attributes:
        points_m: Scan points compared [m], shape (n, 3).
        deviation_m: Signed normal distance to the target, + above it (too shallow) [m], shape (n,).
        rms_m: Root mean square of `deviation_m` [m].
        max_abs_m: Largest |deviation| [m].
        mean_m: Mean deviation [m] (+: the part is shallower than its target on average).
    """

    points_m: np.ndarray
    deviation_m: np.ndarray
    rms_m: float
    max_abs_m: float
    mean_m: float

    def summary_mm(self) -> dict[str, float]:
        """The numbers in millimetres, for a report."""
        return {
            "surface_rms_mm": 1e3 * self.rms_m,
            "surface_max_mm": 1e3 * self.max_abs_m,
            "surface_mean_mm": 1e3 * self.mean_m,
            "surface_points": float(len(self.deviation_m)),
        }


def surface_deviation(points_m: np.ndarray, target: trimesh.Trimesh) -> SurfaceDeviation:
    """Signed normal distances of scan points to a target mesh, over the target's formed region.

    Args:
        points_m: Scanned surface points, sheet frame [m], shape (n, 3).
        target: The target part's upper surface, sheet frame [m] (normals up, e.g. `heightmap_mesh`).

    Raises:
        InputError: The points are not (n, 3) finite values, or none lies over the target's formed region.
    """
    points = np.asarray(points_m, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        raise InputError(f"scan points must be finite (n, 3) values; got shape {points.shape}")
    lo, hi = target.bounds[0], target.bounds[1]
    inside = np.all((points[:, :2] >= lo[:2] + EDGE_M) & (points[:, :2] <= hi[:2] - EDGE_M), axis=1)
    closest, distance, triangle = trimesh.proximity.closest_point(target, points[inside])
    normal = target.face_normals[triangle]
    sign = np.sign(np.einsum("ij,ij->i", points[inside] - closest, normal))
    formed = closest[:, 2] < -COMPARE_BELOW_M
    if not formed.any():
        raise InputError(
            f"no scan point lies over the target's formed region (target {COMPARE_BELOW_M * 1e3:g} mm below the "
            f"sheet, x in [{lo[0] * 1e3:.1f}, {hi[0] * 1e3:.1f}] mm, y in [{lo[1] * 1e3:.1f}, {hi[1] * 1e3:.1f}] mm)"
        )
    deviation = (np.where(sign == 0.0, 1.0, sign) * distance)[formed]
    return SurfaceDeviation(
        points_m=points[inside][formed],
        deviation_m=deviation,
        rms_m=float(np.sqrt(np.mean(deviation**2))),
        max_abs_m=float(np.max(np.abs(deviation))),
        mean_m=float(np.mean(deviation)),
    )


def read_target_mesh(path: str | Path) -> trimesh.Trimesh:
    """A target part mesh from an STL (or any mesh file trimesh reads) in millimetres, as metres.

    Raises:
        DataFileError: The file is missing, is not a mesh, or is in metres (spans less than 1 mm).
    """
    path = Path(path)
    if not path.is_file():
        raise DataFileError(path, "no such target mesh file")
    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:
        raise DataFileError(path, f"not a mesh trimesh can read: {exc}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise DataFileError(path, "holds no triangles")
    span_mm = float(np.max(mesh.extents))
    if span_mm < 1.0:
        raise DataFileError(path, f"spans {span_mm:.3g} units: expected millimetres (a part spans > 1 mm)")
    mesh.apply_scale(1e-3)
    return mesh
