"""The formed groove profile: the lower envelope of the tool sphere over every committed tool position.

Along the groove centre line (y = 0, sheet frame): formed_z(x) = min(formed_z(x), z_t + R - sqrt(R² - (x - x_t)²))
for |x - x_t| < R, R the tool radius (§2.2); initially 0 (flat sheet). A snapshot of the profile, taken when a
pass starts, is the surface the tool meets ahead of it (`twin.process.force.table.SheetForceField`).
"""

from __future__ import annotations

import math

import numpy as np


class FormedProfile:
    """Loaded groove-bottom profile on a regular x grid, and a snapshot of it.

    Args:
        radius_m: Tool sphere radius [m].
        grid_step_m: Spacing of the profile grid [m].
        half_length_m: The grid spans [-half_length_m, half_length_m] [m].

    Attributes:
        radius: Tool sphere radius [m].
        x0: First grid abscissa [m].
        dx: Grid spacing [m].
        n: Number of grid nodes.
        x_grid_m: Grid abscissae [m], shape (n,).
        z_m: Formed profile [m], shape (n,).
        snapshot_m: The profile as it was at the last `take_snapshot` (or `reset`) [m], shape (n,).

    Both arrays are only ever changed in place, never rebound, so a caller may hold them (the force field's
    per-sample hot path reads them without a call layer).
    """

    def __init__(self, radius_m: float, grid_step_m: float, half_length_m: float) -> None:
        self.radius = float(radius_m)
        self.dx = float(grid_step_m)
        self.n = round(2 * half_length_m / self.dx) + 1
        self.x0 = -half_length_m
        self.x_grid_m = self.x0 + self.dx * np.arange(self.n)
        self.z_m = np.zeros(self.n)
        self.snapshot_m = self.z_m.copy()

    def reset(self) -> None:
        """Back to a flat sheet (profile and snapshot 0)."""
        self.z_m[:] = 0.0
        self.snapshot_m[:] = 0.0

    def take_snapshot(self) -> None:
        """Keep a copy of the profile formed so far in `snapshot_m`."""
        np.copyto(self.snapshot_m, self.z_m)

    def commit(self, x: float, z: float) -> None:
        """Lower the profile to the tool sphere with its tip at (x, z) [m]."""
        r = self.radius
        i0 = max(0, math.ceil((x - r - self.x0) / self.dx))
        i1 = min(self.n, math.floor((x + r - self.x0) / self.dx) + 1)
        if i1 <= i0:
            return
        cap = self.x_grid_m[i0:i1] - x  # in place below: z + r - sqrt(max(r² - dx², 0)), ~2x faster
        np.multiply(cap, cap, out=cap)
        np.subtract(r * r, cap, out=cap)
        np.maximum(cap, 0.0, out=cap)
        np.sqrt(cap, out=cap)
        np.subtract(z + r, cap, out=cap)
        formed = self.z_m[i0:i1]
        np.minimum(formed, cap, out=formed)
