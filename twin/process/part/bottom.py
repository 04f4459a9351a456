"""The unsupported bottom of a part: the sheet inside the tool's innermost contour moves down with it.

In single-point ISF the sheet the tool never touches inside a closed contour (a cone's or pyramid's bottom) is
not held by anything but the wall: it hangs from the wall's lower edge and moves down with the tool as a nearly
rigid plate, at about the depth of the tool tip on the last contour (the "pillow" it bulges into is left out).
A height map built as the lower envelope of the tool sphere keeps that region at the flat sheet's height.
`with_floating_bottom` moves it: every region of unformed sheet that the formed surface encloses (not connected
to the sheet's edge) becomes a plate at the height of the surface under the tool's last contour around it, and
so does the rim of the envelope inside that contour.

The last contour is read off the tool-tip track: walking back from the last tip until the tips have turned a
full revolution about the region's centre.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.path import Path as PolygonPath
from scipy import ndimage

from twin.errors import InputError


def _last_revolution(track_m: np.ndarray, centre: np.ndarray) -> np.ndarray | None:
    """The tips of the last full turn of the track about `centre` (k, 3) [m]; None if it never turns once."""
    rel = track_m[:, :2] - centre
    angle = np.arctan2(rel[:, 1], rel[:, 0])
    turned = 0.0
    for i in range(len(angle) - 1, 0, -1):
        step = (angle[i] - angle[i - 1] + math.pi) % (2.0 * math.pi) - math.pi
        turned += step
        if abs(turned) >= 2.0 * math.pi:
            return track_m[i - 1 :]
    return None


def with_floating_bottom(
    x_m: np.ndarray, y_m: np.ndarray, z_m: np.ndarray, track_m: np.ndarray, formed_below_m: float
) -> np.ndarray:
    """The surface with every enclosed, untouched region lowered to the plate its last contour carries [m].

    Args:
        x_m, y_m: Grid axes [m], (nx,), (ny,).
        z_m: Surface heights after the tool has left [m], (ny, nx).
        track_m: The tool-tip track that formed it, sheet frame [m], (n, 3).
        formed_below_m: A node lower than this below the flat sheet counts as formed [m].

    Returns:
        A new height array; `z_m` itself where no region is enclosed or no contour turns around one.

    Raises:
        InputError: Shapes disagree.
    """
    z = np.asarray(z_m, dtype=float)
    if z.shape != (len(y_m), len(x_m)) or np.shape(track_m)[1:] != (3,):
        raise InputError(f"surface {z.shape} must be (len(y), len(x)) = ({len(y_m)}, {len(x_m)}); track (n, 3)")
    labels, count = ndimage.label(z >= -formed_below_m)
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    out = z.copy()
    X, Y = np.meshgrid(np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float))
    h = float(x_m[1] - x_m[0])
    for label in range(1, count + 1):
        if label in border:
            continue
        rows, cols = np.nonzero(labels == label)
        centre = np.array([X[rows, cols].mean(), Y[rows, cols].mean()])
        loop = _last_revolution(np.asarray(track_m, dtype=float), centre)
        if loop is None:
            continue
        # the plate hangs at the surface under the last contour's tips (recovered, as the part is unclamped)
        ix = np.clip(np.round((loop[:, 0] - x_m[0]) / h).astype(int), 0, len(x_m) - 1)
        iy = np.clip(np.round((loop[:, 1] - y_m[0]) / h).astype(int), 0, len(y_m) - 1)
        level = float(np.median(z[iy, ix]))
        # only the nodes in the contour's bounding box can lie inside it (the others are not asked)
        (x0, y0), (x1, y1) = loop[:, :2].min(axis=0), loop[:, :2].max(axis=0)
        inside = (x0 <= X) & (x1 >= X) & (y0 <= Y) & (y1 >= Y)
        inside[inside] = PolygonPath(loop[:, :2]).contains_points(np.column_stack([X[inside], Y[inside]]))
        out[inside] = np.minimum(out[inside], level)
    return out
