"""Vertical rays down onto a mesh, all at once: the height of its first hit above each x-y.

The same test as trimesh's own (`mesh.ray.intersects_location(..., multiple_hits=False)`, its pure-Python
`trimesh.ray.ray_triangle`): the same ray boxes (`ray_bounds`), the same candidate triangles (those whose bounding
box meets the ray's, as its r-tree finds them), plane intersection, barycentric inside test and first hit along the
ray. Only the broad phase differs: trimesh asks the r-tree once per ray from Python, which `design_heights` (a few
hundred thousand rays per part compensation) paid for in seconds; here the triangles are binned on an x-y grid
once and every ray looks up its cell, then the boxes are compared exactly as the r-tree compares them.
"""

from __future__ import annotations

import numpy as np
import trimesh
from trimesh import intersections, util
from trimesh import triangles as triangles_mod
from trimesh.constants import tol
from trimesh.ray.ray_triangle import ray_bounds

#: Triangles are binned over their x-y box widened by this [mesh units], far more than a ray box's half-width
#: (trimesh's 1e-5), so a ray's own cell holds every triangle whose box meets the ray's.
_PAD = 1e-4


def _candidates(lo: np.ndarray, hi: np.ndarray, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(triangle, ray) pairs whose boxes meet: triangles' (n, 3) `lo`/`hi`, rays' (m, 6) `boxes` (min, max); ray by
    ray, triangles in index order within a ray."""
    low, high = lo[:, :2].min(axis=0) - _PAD, hi[:, :2].max(axis=0) + _PAD
    extent = np.maximum(high - low, 1e-12)
    cell = max(float(np.sqrt(extent[0] * extent[1] / len(lo))), float(np.median(hi[:, :2] - lo[:, :2])), 1e-9)
    shape = np.floor(extent / cell).astype(np.int64) + 1
    first = np.clip(np.floor((lo[:, :2] - _PAD - low) / cell).astype(np.int64), 0, shape - 1)
    last = np.clip(np.floor((hi[:, :2] + _PAD - low) / cell).astype(np.int64), 0, shape - 1)
    span = last - first + 1
    per = span[:, 0] * span[:, 1]
    tri = np.repeat(np.arange(len(lo), dtype=np.int64), per)
    k = np.arange(len(tri), dtype=np.int64) - np.repeat(np.cumsum(per) - per, per)
    cells = (first[tri, 0] + k // span[tri, 1]) * shape[1] + first[tri, 1] + k % span[tri, 1]
    order = np.argsort(cells, kind="stable")
    tri, cells = tri[order], cells[order]
    indptr = np.searchsorted(cells, np.arange(shape[0] * shape[1] + 1))
    centre = 0.5 * (boxes[:, :2] + boxes[:, 3:5])
    at = np.floor((centre - low) / cell).astype(np.int64)
    inside = np.all((at >= 0) & (at < shape), axis=1)
    ray = np.flatnonzero(inside)
    cell_of = at[ray, 0] * shape[1] + at[ray, 1]
    count = indptr[cell_of + 1] - indptr[cell_of]
    pair_ray = np.repeat(ray, count)
    pair_tri = tri[np.repeat(indptr[cell_of], count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)]
    meets = np.all((lo[pair_tri] <= boxes[pair_ray, 3:]) & (hi[pair_tri] >= boxes[pair_ray, :3]), axis=1)
    return pair_tri[meets], pair_ray[meets]


def vertical_heights(mesh: trimesh.Trimesh, x: np.ndarray, y: np.ndarray, top: float) -> np.ndarray:
    """z of the first hit of a ray from (x, y, top) straight down onto `mesh` (n,); NaN where it misses."""
    origins = np.column_stack([x, y, np.full(len(x), top)]).astype(np.float64)
    directions = np.tile([0.0, 0.0, -1.0], (len(x), 1))
    z = np.full(len(x), np.nan)
    triangles = np.asanyarray(mesh.triangles, dtype=np.float64)
    if not len(x) or not len(triangles):
        return z
    lo, hi = triangles.min(axis=1), triangles.max(axis=1)
    boxes = ray_bounds(ray_origins=origins, ray_directions=directions, bounds=np.concatenate([lo.min(0), hi.max(0)]))
    candidates, ray_id = _candidates(lo, hi, boxes)
    location, valid = intersections.planes_lines(
        plane_origins=triangles[candidates, 0, :], plane_normals=mesh.face_normals[candidates],
        line_origins=origins[ray_id], line_directions=directions[ray_id],
    )
    if len(candidates) == 0 or not valid.any():
        return z
    barycentric = triangles_mod.points_to_barycentric(triangles[candidates][valid], location)
    hit = np.logical_and((barycentric > -tol.zero).all(axis=1), (barycentric < (1 + tol.zero)).all(axis=1))
    index_ray, location = ray_id[valid][hit], location[hit]
    distance = util.diagonal_dot(location - origins[index_ray], directions[index_ray])
    forward = distance > -1e-6
    index_ray, location, distance = index_ray[forward], location[forward], distance[forward]
    order = np.lexsort((distance, index_ray))  # stable: the first candidate of equal distance, as argmin takes it
    first = order[np.r_[True, np.diff(index_ray[order]) != 0]] if len(order) else order
    z[index_ray[first]] = location[first, 2]
    return z
