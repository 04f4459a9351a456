"""Learning the next part's command from the last part's scan: under each tip, or at the points it formed.

A spatial iterative-learning update (P-type): the next command is the last one moved along z by `gain` times the
scan's vertical error (scan z minus design z, at the scan point's x-y), smoothed along the path. Two laws:
`at="tip"` (the first, the default) reads it under each sample's own tip x-y; `at="formed"` reads the error **of
the surface that sample formed**, which sample formed which point read off the design:

* **The tool at rest on the design.** A sample's tool sphere (radius R, the tool vertical) rests on the design
  above the sample's x-y: its tip height is the highest `z_design(q) + sqrt(R^2 - |q - xy|^2) - R` over the design
  points q within R in x-y (`resting_tips`, on a grid of `GRID_M`). On a wall of slope alpha the sphere touches it
  R sin(alpha) outside the tip and R (1 - cos alpha) above it: on a 45 deg cone with R = 7.5 mm the surface under
  a tip's own x-y lies 3.1 mm below the tip and was formed by the contours 5.3 mm deeper.
* **Who formed a point.** Each scan point belongs to the sample whose sphere's underside is lowest over it among
  the samples within R in x-y (the lower envelope the sheet takes, `forming_samples`); a point no sphere reaches
  (the unsupported bottom inside the last contour, which hangs from it) to the sample nearest in x-y.
* **The update.** Each sample's error is the mean error of the points it formed, smoothed along the path by a
  Gaussian of `smoothing_m` over the counts (a sample that formed no scanned point takes its neighbours' along
  the path); a sample no point maps to within the smoothing takes the error of the path's nearest seen sample.
  A vertical move of the tool moves the surface it forms by the same vertical amount, so the vertical error is
  the move, on walls and flats alike.

On a wall the tip law's updates land 5.3 mm of depth (with R = 7.5 mm) away from the contours that formed the
error it reads; where the error rings with depth (the independent dynamic plant's Ø80 mm cone) it stalls, where
the plant moves less than the command (the quasi-static lab on shallow parts) that misplacement happens to give
the deep bottom's larger error to the wall (docs/any-part.md). Held fixed: x-y, timing.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import trimesh
from scipy.ndimage import gaussian_filter1d
from scipy.spatial import cKDTree

from twin.analysis.part_compensation import design_heights
from twin.errors import InputError

#: The grid the design is sampled on to rest the tool on it [m].
GRID_M = 0.5e-3
#: Where the error is read: at the surface each sample formed, or (the law before) under the tip's own x-y.
LEARN_AT = ("tip", "formed")
#: The tip law reads the scan points within this x-y distance of the tip [m].
TIP_REACH_M = 1.5e-3
_CHUNK = 2000


class LearnedCommand(NamedTuple):
    """`learn_from_scan`'s result.

    Attributes:
        command_m: The next part's command, sheet frame [m], shape (n, 3).
        measured_m: The vertical error of the surface each sample formed, smoothed [m], shape (n,); NaN where no
            scanned point maps within the smoothing (those samples take the nearest seen sample's error).
        formed_points: How many scan points each sample formed, shape (n,).
    """

    command_m: np.ndarray
    measured_m: np.ndarray
    formed_points: np.ndarray


def resting_tips(design: trimesh.Trimesh, xy_m: np.ndarray, radius_m: float) -> np.ndarray:
    """Tip height [m] of a vertical tool sphere of `radius_m` resting on the design above each x-y (n, 2) [m]."""
    xy = np.asarray(xy_m, dtype=float)
    pad = radius_m + 2.0 * GRID_M
    gx = np.arange(xy[:, 0].min() - pad, xy[:, 0].max() + pad + GRID_M, GRID_M)
    gy = np.arange(xy[:, 1].min() - pad, xy[:, 1].max() + pad + GRID_M, GRID_M)
    gz = design_heights(design, *np.meshgrid(gx, gy))
    gz = np.where(np.isfinite(gz), gz, -np.inf)  # off the design: no support
    k = int(np.ceil(radius_m / GRID_M))
    di, dj = (a.ravel() for a in np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1), indexing="ij"))
    tips = np.empty(len(xy))
    for s in range(0, len(xy), _CHUNK):
        p = xy[s : s + _CHUNK]
        ii = np.rint((p[:, 1] - gy[0]) / GRID_M).astype(int)[:, None] + di
        jj = np.rint((p[:, 0] - gx[0]) / GRID_M).astype(int)[:, None] + dj
        d2 = (gx[jj] - p[:, [0]]) ** 2 + (gy[ii] - p[:, [1]]) ** 2
        top = np.where(d2 <= radius_m**2, gz[ii, jj] + np.sqrt(np.maximum(radius_m**2 - d2, 0.0)), -np.inf)
        tips[s : s + _CHUNK] = top.max(axis=1) - radius_m
    return tips


def forming_samples(tips_m: np.ndarray, points_xy_m: np.ndarray, radius_m: float) -> np.ndarray:
    """Index of the sample that formed each point: the lowest sphere underside over it within `radius_m` in x-y,
    else (a point no sphere reaches: the bottom hanging from the last contour) the nearest sample in x-y.
    `tips_m` (n, 3) [m], `points_xy_m` (m, 2) [m]."""
    tree = cKDTree(tips_m[:, :2])
    _, nearest = tree.query(points_xy_m, k=1)
    owner = np.asarray(nearest, dtype=int).copy()
    for i, candidates in enumerate(tree.query_ball_point(points_xy_m, radius_m)):
        if candidates:
            c = np.asarray(candidates)
            d2 = np.sum((tips_m[c, :2] - points_xy_m[i]) ** 2, axis=1)
            owner[i] = c[np.argmin(tips_m[c, 2] - np.sqrt(np.maximum(radius_m**2 - d2, 0.0)))]
    return owner


def learn_from_scan(
    command_m: np.ndarray, scan_m: np.ndarray, design: trimesh.Trimesh, *, gain: float = 1.0,
    smoothing_m: float = 2e-3, tool_radius_m: float = 7.5e-3, at: str = "tip",
) -> LearnedCommand:
    """The next part's command from the last part's scan (module docstring).

    Args:
        command_m: The last part's command, sheet frame [m], shape (n, 3).
        scan_m: Its scan in the sheet frame (registered), shape (m, 3) [m].
        design: The design surface [m].
        gain: Learning gain [-], (0, 1].
        smoothing_m: Gaussian smoothing along the path [m], > 0.
        tool_radius_m: The tool's radius [m], > 0.
        at: One of `LEARN_AT`: "tip" (the first law: each sample takes the error under its own x-y, the
            inverse-distance mean of the scan points within `TIP_REACH_M`, smoothed; samples with none are held)
            or "formed" (the error of the surface the sample formed, module docstring).

    Raises:
        InputError: A gain, smoothing, radius or `at` out of range, or no scan point over the design.
    """
    if not (0.0 < gain <= 1.0 and smoothing_m > 0.0 and tool_radius_m > 0.0) or at not in LEARN_AT:
        raise InputError(f"learning gain {gain} must be in (0, 1], smoothing {1e3 * smoothing_m:g} mm and tool "
                         f"radius {1e3 * tool_radius_m:g} mm > 0, and the error read at {at!r} one of {LEARN_AT}")
    command = np.asarray(command_m, dtype=float)
    scan = np.asarray(scan_m, dtype=float)
    error = scan[:, 2] - design_heights(design, scan[:, 0], scan[:, 1])
    seen = np.isfinite(error)
    if not seen.any():
        raise InputError(f"none of the scan's {len(scan)} points lies over the design: nothing to learn from")
    n = len(command)
    steps = np.linalg.norm(np.diff(command, axis=0), axis=1)
    sigma = smoothing_m / max(float(np.median(steps)) if len(steps) else 0.0, 1e-9)
    if at == "tip":
        return _tip_law(command, scan[seen], error[seen], gain, sigma)
    tips = np.column_stack([command[:, :2], resting_tips(design, command[:, :2], tool_radius_m)])
    owner = forming_samples(tips, scan[seen, :2], tool_radius_m)
    total = np.bincount(owner, weights=error[seen], minlength=n)
    count = np.bincount(owner, minlength=n).astype(float)
    weight = gaussian_filter1d(count, sigma)
    measured = np.where(weight > 1e-3, gaussian_filter1d(total, sigma) / np.maximum(weight, 1e-12), np.nan)
    known = np.flatnonzero(np.isfinite(measured))
    filled = np.interp(np.arange(n), known, measured[known])
    out = command.copy()
    out[:, 2] -= gain * filled
    return LearnedCommand(out, measured, count)


def _tip_law(command: np.ndarray, scan: np.ndarray, error: np.ndarray, gain: float, sigma: float) -> LearnedCommand:
    """The first law: the error under each sample's own x-y (`learn_from_scan`, at="tip")."""
    distance, index = cKDTree(scan[:, :2]).query(command[:, :2], k=4)
    weights = np.where(distance < TIP_REACH_M, 1.0 / np.maximum(distance, 1e-6), 0.0)
    total = weights.sum(axis=1)
    measured = np.where(total > 0, (weights * error[index]).sum(axis=1) / np.maximum(total, 1e-12), np.nan)
    smooth = gaussian_filter1d(np.nan_to_num(measured), sigma)
    out = command.copy()
    out[:, 2] -= gain * np.where(np.isfinite(measured), smooth, 0.0)
    return LearnedCommand(out, measured, (total > 0).astype(float))
