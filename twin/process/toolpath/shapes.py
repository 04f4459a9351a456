"""Tool paths of the standard ISF test parts besides the groove: cone, pyramid, variable-wall-angle cone.

Frame and convention as `twin.process.toolpath.groove`: sheet frame (origin at the centre of the sheet's top surface, z
up), positions are the tool tip. A part is a stack of closed contours of one shape (circle or square) whose
half-width w(d) shrinks with the depth d >= 0 below the sheet; the contour through the tool tip at depth d has
the wall angle α(d) (from the sheet plane), dw/dd = -cot α(d). The offset surface of a cone is a cone of the
same angle, so the tool-tip locus and the formed wall share the wall angle.

* cone: α constant, w(d) = w0 - d·cot α;
* variable-wall-angle cone (the usual formability test): α grows linearly with depth from α0 at the surface
  to α1 at the bottom, α(d) = α0 + b·d, b = (α1 - α0)/H, so w(d) = w0 - ln(sin α(d) / sin α0) / b;
* pyramid: a square contour of half-width w(d) = w0 - d·cot α (sides parallel to x and y).

Two descents (`mode`):

* `spiral`: the depth grows linearly along the perimeter fraction, Δz per revolution, no plunge;
* `z-level`: one closed contour at each depth d_k = k·Δz (k = 1..N), joined by straight step-down moves at
  the contours' start (u = 0, on the +x axis), which belong to the contour they lead into.

The requested step-down is an upper bound: N = ceil(H/Δz) levels of equal step H/N. Pass k is the k-th
revolution or level; `direction` is +1 throughout (counter-clockwise seen from +z; the groove's x-direction
label has no meaning here). Samples are uniform in the perimeter fraction (a multiple of 8 per revolution,
so a pyramid's corners are samples), at most `spacing_m` apart on the widest contour.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from twin.errors import InputError
from twin.process.toolpath.groove import ToolPath, check_samples

SHAPES = ("cone", "pyramid", "vwa-cone")
MODES = ("spiral", "z-level")


@dataclass(frozen=True)
class PartSpec:
    """Geometry, descent and feed of a cone, pyramid or variable-wall-angle cone.

    Attributes:
        shape: `cone`, `pyramid` or `vwa-cone`.
        top_half_width_m: Half-width w0 of the tool-tip contour at the sheet surface [m] (cone: radius;
            pyramid: half the side).
        depth_m: Final depth H [m].
        wall_angle_deg: Wall angle α from the sheet plane [deg] (vwa-cone: α0 at the surface).
        wall_angle_end_deg: vwa-cone only: wall angle α1 at depth H [deg].
        step_down_m: Largest depth increment per revolution or level Δz [m].
        mode: `spiral` or `z-level`.
        feed_m_per_s: Constant tool feed [m/s].
        spacing_m: Largest distance between consecutive samples [m].
    """

    shape: str = "cone"
    top_half_width_m: float = 0.060
    depth_m: float = 0.040
    wall_angle_deg: float = 45.0
    wall_angle_end_deg: float = 70.0
    step_down_m: float = 0.5e-3
    mode: str = "spiral"
    feed_m_per_s: float = 2.0 / 60.0
    spacing_m: float = 0.5e-3

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise InputError(f"PartSpec.shape = {self.shape!r}: expected one of {', '.join(SHAPES)}")
        if self.mode not in MODES:
            raise InputError(f"PartSpec.mode = {self.mode!r}: expected one of {', '.join(MODES)}")
        for name in ("top_half_width_m", "depth_m", "step_down_m", "feed_m_per_s", "spacing_m"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InputError(f"PartSpec.{name} = {value!r}: expected a finite number > 0")
        for name in ("wall_angle_deg", "wall_angle_end_deg"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and 0.0 < value < 90.0):
                raise InputError(f"PartSpec.{name} = {value!r}: expected a wall angle in (0, 90) deg")
        if self.shape == "vwa-cone" and self.wall_angle_end_deg == self.wall_angle_deg:
            raise InputError(
                f"PartSpec: vwa-cone needs wall_angle_end_deg != wall_angle_deg (both {self.wall_angle_deg!r}); "
                "use shape='cone' for a constant wall angle"
            )
        w_end = self.half_width_m(self.depth_m)
        if not w_end > self.spacing_m:
            raise InputError(
                f"PartSpec: the contour closes before depth {self.depth_m * 1e3:.3g} mm (half-width there "
                f"{w_end * 1e3:.3g} mm): for these wall angles top_half_width_m must exceed "
                f"{(self.top_half_width_m - w_end + self.spacing_m) * 1e3:.3g} mm"
            )

    @property
    def levels(self) -> int:
        """Number of revolutions or levels N = ceil(H/Δz)."""
        return max(1, math.ceil(self.depth_m / self.step_down_m - 1e-9))

    def wall_angle_rad(self, depth_m: np.ndarray | float) -> np.ndarray:
        """Wall angle α at depth d [rad]."""
        d = np.asarray(depth_m, dtype=float)
        a0 = math.radians(self.wall_angle_deg)
        if self.shape != "vwa-cone":
            return np.full_like(d, a0)
        return a0 + (math.radians(self.wall_angle_end_deg) - a0) * d / self.depth_m

    def half_width_m(self, depth_m: np.ndarray | float) -> np.ndarray:
        """Half-width w(d) of the tool-tip contour at depth d >= 0 [m] (module docstring)."""
        d = np.asarray(depth_m, dtype=float)
        a0 = math.radians(self.wall_angle_deg)
        if self.shape != "vwa-cone":
            return self.top_half_width_m - d / math.tan(a0)
        b = (math.radians(self.wall_angle_end_deg) - a0) / self.depth_m
        return self.top_half_width_m - np.log(np.sin(a0 + b * d) / math.sin(a0)) / b


def _unit_contour(shape: str) -> Callable[[np.ndarray], np.ndarray]:
    """Map perimeter fractions u (any real; the integer part counts revolutions) to unit-half-width (x, y)."""
    if shape != "pyramid":
        return lambda u: np.column_stack([np.cos(2 * np.pi * u), np.sin(2 * np.pi * u)])

    def square(u: np.ndarray) -> np.ndarray:
        # counter-clockwise from (1, 0): up the x = 1 side, then y = 1, x = -1, y = -1, back to (1, 0)
        s = 8.0 * np.mod(u, 1.0)  # arc length on the unit square's perimeter (8), from (1, 0)
        x = np.interp(s, [0, 1, 3, 5, 7, 8], [1, 1, -1, -1, 1, 1])
        y = np.interp(s, [0, 1, 3, 5, 7, 8], [0, 1, 1, -1, -1, 0])
        return np.column_stack([x, y])

    return square


def _per_revolution(spec: PartSpec) -> int:
    perimeter = (8.0 if spec.shape == "pyramid" else 2.0 * math.pi) * spec.top_half_width_m
    step = spec.depth_m / spec.levels
    per_level = math.hypot(perimeter, step) / spec.spacing_m
    check_samples(spec.levels * per_level * (2.0 if spec.mode == "z-level" else 1.0), spec.spacing_m)
    n = math.ceil(per_level - 1e-9)
    return 8 * math.ceil(n / 8)  # the square's corners sit at u = 1/8, 3/8, 5/8, 7/8


def part_path(spec: PartSpec | None = None) -> ToolPath:
    """Sample the tool-tip path of a cone, pyramid or variable-wall-angle cone (module docstring).

    Args:
        spec: Part geometry, descent and feed; None for a 45° spiral cone, 120 mm across, 40 mm deep.

    Returns:
        The path from (w0, 0, 0) on the sheet surface to the last contour at depth H.
    """
    spec = spec or PartSpec()
    n_rev = _per_revolution(spec)
    levels = spec.levels
    step = spec.depth_m / levels
    contour = _unit_contour(spec.shape)
    if spec.mode == "spiral":
        u = np.arange(levels * n_rev + 1) / n_rev
        depth = step * u
        pass_index = np.concatenate(([1], np.ceil(u[1:] - 1e-12).astype(int)))
    else:
        u_parts, d_parts, k_parts = [np.zeros(1)], [np.zeros(1)], [np.ones(1, dtype=int)]
        for k in range(1, levels + 1):
            w_a, w_b = float(spec.half_width_m((k - 1) * step)), float(spec.half_width_m(k * step))
            plunge = max(1, math.ceil(math.hypot(w_a - w_b, step) / spec.spacing_m - 1e-9))
            f = np.arange(1, plunge + 1) / plunge
            u_parts += [np.zeros(plunge), np.arange(1, n_rev + 1) / n_rev]
            d_parts += [(k - 1 + f) * step, np.full(n_rev, k * step)]
            k_parts.append(np.full(plunge + n_rev, k))
        u, depth, pass_index = np.concatenate(u_parts), np.concatenate(d_parts), np.concatenate(k_parts)
    if spec.mode == "z-level":
        # a plunge runs straight between the two contours' start points (not along the curved wall)
        k_of = pass_index
        on_plunge = np.r_[False, (u[1:] == 0.0)]
        w = np.asarray(spec.half_width_m(depth))
        w_top = np.asarray(spec.half_width_m((k_of - 1) * step))
        w_bottom = np.asarray(spec.half_width_m(k_of * step))
        frac = depth / step - (k_of - 1)
        w = np.where(on_plunge, w_top + frac * (w_bottom - w_top), w)
    else:
        w = np.asarray(spec.half_width_m(depth))
    xy = contour(u) * w[:, None]
    p = np.column_stack([xy, -depth])
    p[0, 2] = 0.0
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    s = np.concatenate(([0.0], np.cumsum(steps)))
    return ToolPath(
        t_s=s / spec.feed_m_per_s,
        p_sheet_m=p,
        pass_index=pass_index.astype(int),
        direction=np.ones(len(p), dtype=int),
    )
