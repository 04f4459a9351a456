"""What the plant's sheet laws share: the formed-surface grid's layout, its sections, and the travel state.

Each law (`sheet.py`, `sheet_patch.py`) forms its own surface by its own rule on the same grid (0.5 mm; the knob
`sheet_grid_mm`); how a section is read off it and how a direction state turns with the tip's travel are one piece of
code here.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np

from twin.errors import InputError
from twin.process.description import Process

GRID_SPACING_M = 5e-4  # formed-surface grid [m], by default (the knob `sheet_grid_mm`)
HALF_SIZE_M = 0.12  # the grid covers +/- this around the sheet origin [m]


class GridSheet(ABC):
    """A sheet on the grid: its loaded surface `z_m` (ny, nx) over nodes `x_m`, `y_m` [m]; a law adds the rest."""

    x_m: np.ndarray
    y_m: np.ndarray
    z_m: np.ndarray

    def _grid(self, process: Process, timestep_s: float, spacing_m: float) -> None:
        """The declared sheet and tool (thickness, tool radius and friction) [SI] and the grid's nodes, `spacing_m`
        [m] apart (a whole number of them across the grid)."""
        cells = 2 * HALF_SIZE_M / spacing_m
        if not (math.isfinite(cells) and cells >= 1.0 and abs(cells - round(cells)) <= 1e-6 * cells):
            raise InputError(f"sheet_grid_mm = {1e3 * spacing_m:g}: expected a spacing that divides the plant sheet's "
                             f"{2e3 * HALF_SIZE_M:g} mm grid (0.5, 0.25, 0.2, 0.125, 0.1, ...)")
        self.spacing = float(spacing_m)
        self.timestep_s = float(timestep_s)
        self.radius = float(process.tool_radius_m)
        self.t0 = float(process.thickness_m)
        self.mu = float(process.tool_friction)
        n = round(cells) + 1
        self.x_m = np.linspace(-HALF_SIZE_M, HALF_SIZE_M, n)
        self.y_m = self.x_m.copy()

    def height(self, x: float, y: float) -> float:
        """Formed (loaded) surface at (x, y) [m], bilinear; 0 off the grid."""
        fx = (x + HALF_SIZE_M) / self.spacing
        fy = (y + HALF_SIZE_M) / self.spacing
        ix, iy = math.floor(fx), math.floor(fy)
        if ix < 0 or iy < 0 or ix >= len(self.x_m) - 1 or iy >= len(self.y_m) - 1:
            return 0.0
        u, v = fx - ix, fy - iy
        z = self.z_m
        low = z[iy, ix] * (1 - u) + z[iy, ix + 1] * u
        high = z[iy + 1, ix] * (1 - u) + z[iy + 1, ix + 1] * u
        return float(low * (1 - v) + high * v)

    @abstractmethod
    def unloaded_surface(self) -> np.ndarray:
        """The surface after unclamping [m], (ny, nx): each law's own springback."""

    def section(self) -> tuple[np.ndarray, np.ndarray]:
        """The loaded surface along y = 0: x [m], z [m]."""
        return self.x_m.copy(), self._row(self.z_m)

    def unloaded_section(self) -> tuple[np.ndarray, np.ndarray]:
        """The surface after unclamping along y = 0: x [m], z [m]."""
        return self.x_m.copy(), self._row(self.unloaded_surface())

    def _share(self, mask: np.ndarray, x: float, y: float, rho: float) -> float:
        """The share [-] of `mask` around (x, y) [m], weighted by the smooth bump (1 - (d / rho)^2)^2 over the disc
        d < rho [m]: continuous in (x, y); 0 off the grid."""
        h = self.spacing
        i0 = max(math.ceil((x - rho + HALF_SIZE_M) / h), 0)
        i1 = min(math.floor((x + rho + HALF_SIZE_M) / h), len(self.x_m) - 1)
        j0 = max(math.ceil((y - rho + HALF_SIZE_M) / h), 0)
        j1 = min(math.floor((y + rho + HALF_SIZE_M) / h), len(self.y_m) - 1)
        total = pressed = 0.0
        for j in range(j0, j1 + 1):
            dy = (j * h - HALF_SIZE_M - y) / rho
            for i in range(i0, i1 + 1):
                dx = (i * h - HALF_SIZE_M - x) / rho
                q = 1.0 - dx * dx - dy * dy
                if q > 0.0:
                    total += q * q
                    if mask[j, i]:
                        pressed += q * q
        return pressed / total if total > 0.0 else 0.0

    def _row(self, z: np.ndarray) -> np.ndarray:
        iy = round(HALF_SIZE_M / self.spacing)
        return z[iy].copy()


def turned(state: np.ndarray, push: np.ndarray) -> np.ndarray:
    """A direction state pushed by `push` (gain x the tip's step), held to norm <= 1."""
    out = state + push
    norm = float(np.hypot(*out))
    return out / norm if norm > 1.0 else out
