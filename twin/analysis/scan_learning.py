"""Learning the next part's command from the last part's scan: against the twin, at the points each sample formed,
or under each tip.

Three laws (`LEARN_AT`):

* **twin** (`twin_discrepancy`, the CLI's default): the twin replays the last part's command; the scan's vertical
  miss of the twin's predicted part (scan z minus the twin's at the scan point's x-y, Gaussian-weighted over x-y)
  is the twin's error, held fixed from part to part, and the twin's part compensation
  (`twin.analysis.part_compensation.compensate_part(discrepancy=...)`) aims its part at the design minus it. The
  twin carries which contour forms which point and how the part answers a change of the command (the robot's
  deflection and the sheet's force and springback rise with the depth commanded); the scan carries what the twin
  does not know. Where the cell answers otherwise than the twin the held miss is off by the difference, and the
  next part corrects it.
* **formed** and **tip** (`learn_from_scan`, P-type spatial iterative learning): the last command moved along z by
  `gain` times the scan's vertical error (scan z minus design z, at the scan point's x-y), smoothed along the path;
  the part is taken to move as the command does. `at="tip"` reads it under each sample's own tip x-y; `at="formed"`
  reads the error **of the surface that sample formed**, which sample formed which point read off the design:

  * *The tool at rest on the design.* A sample's tool sphere (radius R, the tool vertical) rests on the design
    above the sample's x-y: its tip height is the highest `z_design(q) + sqrt(R^2 - |q - xy|^2) - R` over the
    design points q within R in x-y (`resting_tips`, on a grid of `GRID_M`). On a wall of slope alpha the sphere
    touches it R sin(alpha) outside the tip and R (1 - cos alpha) above it: on a 45 deg cone with R = 7.5 mm the
    surface under a tip's own x-y lies 3.1 mm below the tip and was formed by the contours 5.3 mm deeper.
  * *Who formed a point.* Each scan point belongs to the sample whose sphere's underside is lowest over it among
    the samples within R in x-y (the lower envelope the sheet takes, `forming_samples`); a point no sphere reaches
    (the unsupported bottom inside the last contour, which hangs from it) to the sample nearest in x-y.
  * *The update.* Each sample's error is the mean error of the points it formed, smoothed along the path by a
    Gaussian of `smoothing_m` over the counts (a sample that formed no scanned point takes its neighbours' along
    the path); a sample no point maps to within the smoothing takes the error of the path's nearest seen sample.

  On a wall the tip law's updates land 5.3 mm of depth (with R = 7.5 mm) away from the contours that formed the
  error it reads; where the error rings with depth it stalls. The part compensation reads the twin's predicted
  error the `formed` way.

Held fixed by all three: x-y of the path, timing.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import trimesh
from scipy.ndimage import gaussian_filter1d
from scipy.spatial import cKDTree

from twin.analysis.surface_check import design_heights, surface_heights
from twin.errors import InputError

#: The grid the design is sampled on to rest the tool on it [m].
GRID_M = 0.5e-3
#: Where the error is read: against the twin's own prediction of the last part, at the surface each sample formed,
#: or under the tip's own x-y.
LEARN_AT = ("twin", "formed", "tip")
#: The tip law reads the scan points within this x-y distance of the tip [m].
TIP_REACH_M = 1.5e-3
_CHUNK = 2000
#: The twin law averages at most this many nearest scan points per query (on a 1 mm scan with the 2 mm default
#: width they reach about 4.5 mm, where the Gaussian weight is below a tenth).
NEAREST = 64


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
    laws = ("tip", "formed")  # the twin law learns a field for `compensate_part` (`twin_discrepancy`)
    if not (0.0 < gain <= 1.0 and smoothing_m > 0.0 and tool_radius_m > 0.0) or at not in laws:
        raise InputError(f"learning gain {gain} must be in (0, 1], smoothing {1e3 * smoothing_m:g} mm and tool "
                         f"radius {1e3 * tool_radius_m:g} mm > 0, and the error read at {at!r} one of {laws}")
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


def twin_discrepancy(
    scan_m: np.ndarray, predicted: tuple[np.ndarray, np.ndarray, np.ndarray], smoothing_m: float = 2e-3,
) -> Callable[[np.ndarray], np.ndarray]:
    """The last part's vertical miss of the twin's prediction, as a field over x-y (the `twin` law).

    Args:
        scan_m: The last part's scan in the sheet frame (registered) [m] (m, 3).
        predicted: The twin's part after unclamping for the same command (x, y, z grid,
            `twin.analysis.part_compensation.predicted_surface`) [m].
        smoothing_m: Gaussian width over x-y of the field [m], > 0.

    Returns:
        A function of x-y points (n, 2) [m]: the Gaussian-weighted mean of scan z minus the twin's z over the
        `NEAREST` nearest scan points within 3 widths [m] (n,); NaN where none lies that close.

    Raises:
        InputError: A width out of range, or no scan point over the twin's surface.
    """
    if not smoothing_m > 0.0:
        raise InputError(f"learning smoothing {1e3 * smoothing_m:g} mm: expected > 0")
    scan = np.asarray(scan_m, dtype=float)
    miss = scan[:, 2] - surface_heights(predicted, scan)
    seen = np.isfinite(miss)
    if not seen.any():
        raise InputError(f"none of the scan's {len(scan)} points lies over the twin's part: nothing to learn from")
    tree, values = cKDTree(scan[seen, :2]), miss[seen]
    reach = 3.0 * smoothing_m

    def field(xy_m: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy_m, dtype=float)
        out = np.full(len(xy), np.nan)
        for s in range(0, len(xy), _CHUNK):
            distance, index = tree.query(xy[s : s + _CHUNK], k=min(NEAREST, len(values)), distance_upper_bound=reach)
            distance, index = np.atleast_2d(distance), np.atleast_2d(index)
            near = np.isfinite(distance)
            w = np.where(near, np.exp(-0.5 * (np.where(near, distance, 0.0) / smoothing_m) ** 2), 0.0)
            v = values[np.where(near, index, 0)]
            total = w.sum(axis=1)
            out[s : s + _CHUNK] = np.where(total > 0, (w * v).sum(axis=1) / np.maximum(total, 1e-300), np.nan)
        return out

    return field


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
