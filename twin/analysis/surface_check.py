"""A CAD-like check of a formed part: the scanned surface against the target part's mesh.

Each scan point's deviation is its signed distance to the target mesh along the mesh's normal (the closest
point on the mesh, `trimesh.proximity.closest_point`, run in millimetres: `signed_distance`): positive when the part lies above the target (formed
too shallow, the usual error of a compliant robot pushed back by the sheet), negative below. Only points over
the target's formed region count (the target at least `COMPARE_BELOW_M` below the flat sheet, and no closer
than `EDGE_M` to the mesh's border, where the closest point is the border and not the surface).

`region_deviation` reports the same distances by region of the design (the part as CAD gives it, `path
--design-stl`), each scan point over the design's interior classed by the design at its closest point: `wall`
(slope above `WALL_SLOPE_DEG`), `bottom` (flat and more than `BOTTOM_BELOW_M` below the sheet), `rim` (flat,
within `RIM_WIDTH_M` of the formed region: the sheet at the part's edge, the top fillet's flat end included) and
`sheet` (the flat sheet farther out). `DesignIndex` samples a design densely (faces split to `INDEX_EDGE_M`) for
the fast nearest-face look-ups of the registration (`twin.analysis.scan_registration`) and the rim's distance.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from twin.base.lazy import lazy_module
from twin.errors import DataFileError, InputError

if TYPE_CHECKING:
    import trimesh
else:  # trimesh and scipy load when a surface is first compared
    trimesh = lazy_module("trimesh")

COMPARE_BELOW_M = 1e-4  # the part is compared where the target lies this far below the flat sheet [m]
EDGE_M = 1e-3  # scan points this close to the target mesh's border (in x, y) are not compared [m]
WALL_SLOPE_DEG = 10.0  # the design is a wall where it is steeper than this [deg]
BOTTOM_BELOW_M = 0.5e-3  # a flat design point this far below the sheet is the part's bottom [m]
RIM_WIDTH_M = 3e-3  # flat sheet this close (in x, y) to the formed region is the part's rim [m]
INDEX_EDGE_M = 1e-3  # the design's faces are split to this edge length for the index [m]
REGIONS = ("wall", "bottom", "rim", "sheet")


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
    points = _points(points_m)
    points = points[over_interior(points, target)]
    closest, deviation, _ = signed_distance(millimetre_copy(target), points)
    return _formed(points, closest, deviation, target)


def _formed(points: np.ndarray, closest: np.ndarray, deviation: np.ndarray, target: trimesh.Trimesh) -> SurfaceDeviation:
    """`surface_deviation` of the points whose closest target points [m] lie in its formed region."""
    formed = closest[:, 2] < -COMPARE_BELOW_M
    if not formed.any():
        lo, hi = target.bounds[0], target.bounds[1]
        raise InputError(
            f"no scan point lies over the target's formed region (target {COMPARE_BELOW_M * 1e3:g} mm below the "
            f"sheet, x in [{lo[0] * 1e3:.1f}, {hi[0] * 1e3:.1f}] mm, y in [{lo[1] * 1e3:.1f}, {hi[1] * 1e3:.1f}] mm)"
        )
    deviation = deviation[formed]
    return SurfaceDeviation(
        points_m=points[formed],
        deviation_m=deviation,
        rms_m=float(np.sqrt(np.mean(deviation**2))),
        max_abs_m=float(np.max(np.abs(deviation))),
        mean_m=float(np.mean(deviation)),
    )


def _points(points_m: np.ndarray) -> np.ndarray:
    points = np.asarray(points_m, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        raise InputError(f"scan points must be finite (n, 3) values; got shape {points.shape}")
    return points


def over_interior(points_m: np.ndarray, design: trimesh.Trimesh) -> np.ndarray:
    """Which points lie over the design's interior in x and y (`EDGE_M` inside its bounds), shape (n,)."""
    lo, hi = design.bounds[0][:2] + EDGE_M, design.bounds[1][:2] - EDGE_M
    return np.all((points_m[:, :2] >= lo) & (points_m[:, :2] <= hi), axis=1)


def millimetre_copy(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh in millimetres, for `signed_distance`."""
    scaled = mesh.copy()
    scaled.apply_scale(1e3)
    return scaled


def signed_distance(mesh_mm: trimesh.Trimesh, points_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closest points [m], signed distances along the closest face's normal [m] (+ above; 0 counts +) and
    the normals, each point's on a mesh given in millimetres.

    `trimesh.proximity.closest_point` runs on millimetres: its tolerances are absolute (1e-8), and on a mesh of
    0.5 mm faces in metres they pick another face, up to 0.25 mm off.
    """
    if not len(points_m):
        return np.empty((0, 3)), np.empty(0), np.empty((0, 3))
    closest, distance, triangle = trimesh.proximity.closest_point(mesh_mm, 1e3 * points_m)
    normal = mesh_mm.face_normals[triangle]
    sign = np.sign(np.einsum("ij,ij->i", 1e3 * points_m - closest, normal))
    return 1e-3 * closest, 1e-3 * np.where(sign == 0.0, 1.0, sign) * distance, normal


def read_target_mesh(path: str | Path) -> trimesh.Trimesh:
    """A target or design part mesh from an STL in millimetres, as metres; an STL is read from its bytes
    (`twin.process.part.stl`), another mesh format by trimesh with the format named (no detection).

    Raises:
        DataFileError: The file is missing, is not a mesh, is in metres (spans less than 1 mm), or is not a surface a
            part can be (`part_surface_problem`); naming the file and what was expected.
    """
    path = Path(path)
    if not path.is_file():
        raise DataFileError(path, "no such target mesh file")
    suffix = path.suffix.lower().lstrip(".")
    if suffix == "stl" or suffix not in _MESH_FORMATS:
        from twin.process.part.stl import read_stl_triangles

        triangles = read_stl_triangles(path)
        with np.errstate(all="ignore"):
            mesh = trimesh.Trimesh(vertices=triangles.reshape(-1, 3), faces=np.arange(3 * len(triangles)).reshape(-1, 3))
    else:
        mesh = _other_mesh(path, suffix)
    if len(mesh.faces) == 0:
        raise DataFileError(path, "holds no triangles; expected an STL of the part in millimetres")
    if not np.all(np.isfinite(mesh.vertices)):
        raise DataFileError(path, "holds a vertex that is not a finite number; expected an STL in millimetres")
    span_mm = float(np.max(mesh.extents))
    if span_mm < 1.0:
        raise DataFileError(path, f"spans {span_mm:.3g} units: expected millimetres (a part spans > 1 mm)")
    problem = part_surface_problem(mesh)
    if problem:
        raise DataFileError(path, f"{problem}; expected the part's surface as `path --design-stl` writes it")
    mesh.apply_scale(1e-3)
    return mesh


#: Mesh formats other than STL that `read_target_mesh` hands to trimesh (with the format named).
_MESH_FORMATS = ("obj", "ply", "off")


def _other_mesh(path: Path, suffix: str) -> trimesh.Trimesh:
    """A .obj/.ply/.off mesh read by trimesh with its format named; a missing optional package is said as such."""
    try:
        with np.errstate(all="ignore"):  # a non-finite vertex is refused by the caller, not warned about
            mesh = trimesh.load(path, file_type=suffix, force="mesh")
    except ImportError:
        raise DataFileError(path, f"a .{suffix} mesh this installation cannot read (an optional package trimesh needs "
                                  "for it is missing); expected a binary or ASCII STL in millimetres") from None
    except Exception as exc:
        raise DataFileError(path, f"not a .{suffix} mesh ({type(exc).__name__}: {str(exc)[:80]}); expected a binary "
                                  "or ASCII STL in millimetres") from None
    if not isinstance(mesh, trimesh.Trimesh):
        raise DataFileError(path, "holds no triangles; expected an STL of the part in millimetres")
    return mesh


def part_surface_problem(mesh: trimesh.Trimesh) -> str | None:
    """Why a mesh cannot be a formed sheet part's surface, or None.

    A sheet part is a surface: every edge lies on one triangle (its border) or two (inside); an edge shared by three
    or more triangles (fins, T-junctions of separate sheets) is no surface a tool forms, and the signed distance to
    it has no meaning. A mesh whose triangles all have zero area has no surface at all.
    """
    if float(mesh.area) <= 0.0:
        return "all its triangles have zero area: no surface"
    edges, counts = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    shared = counts > 2
    if shared.any():
        first = edges[np.argmax(shared)]
        a, b = (", ".join(f"{v:.6g}" for v in mesh.vertices[i]) for i in first)
        return (f"is not a surface a part can be: {int(shared.sum())} edge(s) shared by 3 or more triangles (non-"
                f"manifold; e.g. ({a}) - ({b}) shared by {int(counts[np.argmax(shared)])})")
    return None


class DesignIndex:
    """A design mesh sampled at the centroids of its faces split to `INDEX_EDGE_M`, with their normals.

    Attributes:
        mesh: The design [m]; mesh_mm: the same in millimetres (`signed_distance`); centres (m, 3) [m] and
            normals (m, 3): the samples; formed (m,): samples more than `COMPARE_BELOW_M` below the sheet.
    """

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        self.mesh = mesh
        self.mesh_mm = millimetre_copy(mesh)
        vertices, faces = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=INDEX_EDGE_M)
        fine = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
        keep = fine.area_faces > 0.0
        self.centres = np.asarray(fine.triangles_center[keep])
        self.normals = np.asarray(fine.face_normals[keep])
        from scipy.spatial import cKDTree

        self.tree = cKDTree(self.centres)
        self.formed = self.centres[:, 2] < -COMPARE_BELOW_M
        self.formed_xy = cKDTree(self.centres[self.formed, :2]) if self.formed.any() else None

    def nearest(self, points_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each point's distance to the plane of the nearest sample's face (+ along its normal), the sample and
        the normal: (n,), (n, 3), (n, 3)."""
        _, index = self.tree.query(points_m)
        centre, normal = self.centres[index], self.normals[index]
        return np.einsum("ij,ij->i", points_m - centre, normal), centre, normal

    def classify(self, closest_m: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """The region index (into `REGIONS`) of design points with their normals, shape (n,)."""
        wall = normal[:, 2] < np.cos(np.radians(WALL_SLOPE_DEG))
        bottom = ~wall & (closest_m[:, 2] < -BOTTOM_BELOW_M)
        near = np.zeros(len(closest_m), dtype=bool)
        if self.formed_xy is not None:
            near = self.formed_xy.query(closest_m[:, :2], distance_upper_bound=RIM_WIDTH_M)[0] <= RIM_WIDTH_M
        return np.select([wall, bottom, near], [0, 1, 2], default=3)


@dataclass(frozen=True)
class RegionDeviation:
    """Deviation of a scan from its design, by region (`REGIONS`).

    Attributes:
        points_m: Scan points over the design's interior, sheet frame [m] (n, 3).
        deviation_m: Signed normal distance to the design, + above it (too shallow) [m] (n,).
        region: Index into `REGIONS` of each point (n,).
    """

    points_m: np.ndarray
    deviation_m: np.ndarray
    region: np.ndarray

    def stats_mm(self) -> dict[str, dict[str, float]]:
        """Per region with points: rms, max |.|, mean [mm] and the number of points."""
        out: dict[str, dict[str, float]] = {}
        for index, name in enumerate(REGIONS):
            d = 1e3 * self.deviation_m[self.region == index]
            if len(d):
                out[name] = {"rms_mm": float(np.sqrt(np.mean(d**2))), "max_mm": float(np.max(np.abs(d))),
                             "mean_mm": float(np.mean(d)), "points": float(len(d))}
        return out


def region_deviation(points_m: np.ndarray, design: trimesh.Trimesh | DesignIndex) -> RegionDeviation:
    """Signed normal distances of scan points to a design, each classed by the design's region there.

    Args:
        points_m: Scan points, sheet frame (registered) [m] (n, 3).
        design: The design surface, sheet frame [m] (normals up), or its index.

    Raises:
        InputError: Not (n, 3) finite points, or none over the design's interior.
    """
    index = design if isinstance(design, DesignIndex) else DesignIndex(design)
    points = _points(points_m)
    points = points[over_interior(points, index.mesh)]
    if not len(points):
        raise InputError("no scan point lies over the design's interior")
    closest, deviation, normal = signed_distance(index.mesh_mm, points)
    return RegionDeviation(points, deviation, index.classify(closest, normal))


def deviations(points_m: np.ndarray, index: DesignIndex) -> tuple[SurfaceDeviation, RegionDeviation]:
    """`surface_deviation` and `region_deviation` of the same scan points from one closest-point query.

    Raises:
        InputError: As `surface_deviation`.
    """
    points = _points(points_m)
    points = points[over_interior(points, index.mesh)]
    closest, deviation, normal = signed_distance(index.mesh_mm, points)
    surface = _formed(points, closest, deviation, index.mesh)
    return surface, RegionDeviation(points, deviation, index.classify(closest, normal))


def design_heights(design: trimesh.Trimesh, x_m: np.ndarray, y_m: np.ndarray) -> np.ndarray:
    """z of the design surface above each (x, y) [m] (the highest hit of a vertical ray; NaN off the design)."""
    from twin.analysis.design_rays import vertical_heights  # trimesh's ray test, its broad phase in bulk

    x, y = np.ravel(x_m), np.ravel(y_m)
    return vertical_heights(design, x, y, float(design.bounds[1, 2]) + 1.0).reshape(np.shape(x_m))


def surface_heights(surface: tuple[np.ndarray, np.ndarray, np.ndarray], p_m: np.ndarray) -> np.ndarray:
    """z of a gridded surface (x, y, z grid, as `predicted_surface`) at each point's x-y (n, >=2) [m]; NaN off it."""
    from scipy.interpolate import RegularGridInterpolator

    x, y, z = surface
    return np.asarray(RegularGridInterpolator((y, x), z, bounds_error=False, fill_value=np.nan)(p_m[:, [1, 0]]))
