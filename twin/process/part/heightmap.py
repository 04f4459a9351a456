"""The formed sheet as a 2-D height map: the lower envelope of the tool sphere over every committed position.

Sheet frame (origin at the centre of the sheet's top surface, z up). On a regular (x, y) grid of spacing h
(<= 0.5 mm), the loaded surface starts flat at 0 and every committed tool-tip position (x_t, y_t, z_t) lowers it
to the tool sphere of radius R (§2.2: R_T = 7.5 mm):

    z(x, y) <- min(z(x, y), z_t + R - sqrt(R² - (x - x_t)² - (y - y_t)²))   for (x - x_t)² + (y - y_t)² < R².

Each cell remembers which commit last lowered it (its *owner*: a tool-tip position and the normal force then),
so a force model can ask which earlier tool position formed the surface under the tool.

Two surfaces are kept:

* `z_loaded_m`: every commit, the surface under load (what the tool has pressed; assembled on demand);
* the *met* surface: the commits older than `lag_m` of tool travel, the surface the tool meets ahead of it.
  Without the lag the sphere's own last positions, a fraction of a millimetre behind, would hide the material
  the tool is forming (their envelope passes within micrometres of the tool tip).

Elastic recovery: when the tool leaves, a cell springs back by the elastic deflection its owner's contact
caused, f_z/k_unload (k_unload the sheet's unloading stiffness, `twin.process.force.table.K_UNLOAD_N_PER_M`), never
above the flat sheet (`unloaded_z_m`). Commits outside the grid are clipped (the sheet is clamped there).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from twin.errors import InputError

#: Largest grid spacing the force model is validated for [m].
MAX_SPACING_M = 0.5e-3
#: Sub-cell resolution of the tool-tip position in the envelope update (1/16 of the grid spacing).
SUBSTEPS = 16


class HeightMap:
    """Loaded and met surfaces of the sheet on a regular grid, with the owner of every cell.

    Args:
        radius_m: Tool sphere radius R [m].
        spacing_m: Grid spacing h, at most 0.5 mm [m].
        half_size_m: The grid spans [-a, a] x [-b, b] for (a, b) [m].
        lag_m: Tool travel after which a commit enters the met surface [m]; default 1.5·R.

    Attributes:
        x_m: Grid abscissae (nx,) [m]; y_m: ordinates (ny,) [m]; arrays are indexed [iy, ix].
    """

    def __init__(
        self,
        radius_m: float = 7.5e-3,
        spacing_m: float = MAX_SPACING_M,
        half_size_m: tuple[float, float] = (0.12, 0.12),
        lag_m: float | None = None,
    ) -> None:
        for name, value in (("radius_m", radius_m), ("spacing_m", spacing_m), *zip(("half_size_m[0]",
                            "half_size_m[1]"), half_size_m, strict=True)):
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"HeightMap {name} = {value!r}: expected a finite number > 0")
        if spacing_m > MAX_SPACING_M + 1e-15:
            raise InputError(f"HeightMap spacing_m = {spacing_m!r}: expected at most {MAX_SPACING_M} m (0.5 mm)")
        self.radius = float(radius_m)
        self.h = float(spacing_m)
        self.lag = 1.5 * self.radius if lag_m is None else float(lag_m)
        if not (math.isfinite(self.lag) and self.lag >= 0):
            raise InputError(f"HeightMap lag_m = {lag_m!r}: expected a finite number >= 0")
        nx = round(2 * half_size_m[0] / self.h) + 1
        ny = round(2 * half_size_m[1] / self.h) + 1
        self.x0, self.y0 = -half_size_m[0], -half_size_m[1]
        self.x_m = self.x0 + self.h * np.arange(nx)
        self.y_m = self.y0 + self.h * np.arange(ny)
        self.z_met_m = np.zeros((ny, nx))
        self.owner_met = np.full((ny, nx), -1, dtype=np.int64)  # index into the track, -1: never formed
        self._track: list[tuple[float, float, float, float, int]] = []  # (x, y, z, f_z, parent)
        self._restored: np.ndarray | None = None  # the track `restore` took over, rows made on demand (`_rows`)
        self._s = 0.0  # tool travel so far [m]
        self._queue: deque[tuple[float, int, slice, slice, np.ndarray]] = deque()
        self._half_window = math.ceil(self.radius / self.h)
        self._templates: dict[tuple[int, int], np.ndarray] = {}
        self._template_stack: np.ndarray | None = None

    def reset(self) -> None:
        """Back to a flat, unformed sheet."""
        self.z_met_m.fill(0.0)
        self.owner_met.fill(-1)
        self._track.clear()
        self._restored = None
        self._s = 0.0
        self._queue.clear()

    def _rows(self) -> list[tuple[float, float, float, float, int]]:
        """The track as rows (x, y, z, f_z, parent), made from a restored track on first use."""
        if self._restored is not None:
            self._track[:] = [(x, y, z, f, int(p)) for x, y, z, f, p in self._restored.tolist()]
            self._restored = None
        return self._track

    @property
    def half_window(self) -> int:
        """Half-width of the square window a commit lowers, ceil(R / h) cells (the window is 2·m + 2 wide)."""
        return self._half_window

    @property
    def is_fresh(self) -> bool:
        """No commit yet (flat, or reset)."""
        return not self._track and self._restored is None and not self._queue

    def templates(self) -> np.ndarray:
        """Every snapped sphere template, [bu, bv] for a tip at cell offset (bu, bv)/`SUBSTEPS` (S+1, S+1, w, w)
        (made once, shared: not to be written)."""
        if self._template_stack is None:
            self._template_stack = np.array([[self._template(bu / SUBSTEPS, bv / SUBSTEPS)
                                              for bv in range(SUBSTEPS + 1)] for bu in range(SUBSTEPS + 1)])
        return self._template_stack

    def restore(self, track: np.ndarray, travel_m: float, pending_from: int) -> None:
        """Take over the commits of a loop that lowered `z_met_m`/`owner_met` itself (the compiled replay).

        Args:
            track: One row per commit: x, y, z [m], f_z [N], parent, the travel at the commit [m] (n, >= 6).
            travel_m: Tool travel after the last commit [m].
            pending_from: First commit not yet in the met surface (still within the lag).
        """
        self._track.clear()
        self._restored = np.array(track[:, :5], dtype=float) if len(track) else None
        self._s = float(travel_m)
        self._queue.clear()
        for i in range(pending_from, len(track)):
            patch = self._patch(float(track[i, 0]), float(track[i, 1]), float(track[i, 2]))
            if patch is not None:
                self._queue.append((float(track[i, 5]), i, *patch))

    @property
    def track_m(self) -> np.ndarray:
        """Committed tool-tip positions (n, 3) [m] (a copy)."""
        if self._restored is not None:
            return self._restored[:, :3].copy()
        return np.array([row[:3] for row in self._track]).reshape(-1, 3)

    @property
    def commit_f_z_n(self) -> np.ndarray:
        """The tool's vertical force at each commit (n,) [N] (a copy)."""
        if self._restored is not None:
            return self._restored[:, 3].copy()
        return np.array([row[3] for row in self._track], dtype=float)

    @property
    def z_loaded_m(self) -> np.ndarray:
        """Loaded surface, every commit (the met surface and the commits still in the lag) [m], (ny, nx)."""
        z = self.z_met_m.copy()
        for _, _, sy, sx, cap in self._queue:
            view = z[sy, sx]
            np.minimum(view, cap, out=view)
        return z

    def owner_point(self, index: int) -> tuple[float, float, float, float, int]:
        """(x, y, z, f_z, parent) of commit `index` [m, N, -]: parent is the commit that had formed the met
        surface under it when it was made (-1: flat sheet)."""
        return self._rows()[index]

    def commit(
        self, p_sheet_m: np.ndarray | tuple[float, float, float], f_z_n: float = 0.0, parent: int | None = None
    ) -> None:
        """The tool tip passed through `p_sheet_m` pressing with normal force `f_z_n`; lower the loaded surface.

        Args:
            p_sheet_m: Tool-tip position (3,) [m].
            f_z_n: Vertical force of the sheet on the tool there [N] (for the elastic recovery).
            parent: `met_owner` at the tip, if the caller has it already (None: looked up).
        """
        x, y, z = float(p_sheet_m[0]), float(p_sheet_m[1]), float(p_sheet_m[2])
        track = self._rows()
        if track:
            last = track[-1]
            self._s += math.sqrt((x - last[0]) ** 2 + (y - last[1]) ** 2 + (z - last[2]) ** 2)
        index = len(track)
        track.append((x, y, z, float(f_z_n), self.met_owner(x, y) if parent is None else parent))
        patch = self._patch(x, y, z)
        if patch is not None:
            sy, sx, cap = patch
            self._queue.append((self._s, index, sy, sx, cap))
        while self._queue and self._s - self._queue[0][0] >= self.lag:
            _, i, sy, sx, cap = self._queue.popleft()
            _lower(self.z_met_m, self.owner_met, sy, sx, cap, i)

    def _patch(self, x: float, y: float, z: float) -> tuple[slice, slice, np.ndarray] | None:
        """Grid window under the sphere and the sphere's lower surface there (inf outside its footprint).

        The tip's offset within its grid cell is snapped to 1/`SUBSTEPS` of the spacing, so the sphere's shape
        on the window comes from a cache of templates (≤ 16 µm of horizontal shift at h = 0.5 mm).
        """
        h = self.h
        u, v = (x - self.x0) / h, (y - self.y0) / h
        iu, iv = math.floor(u), math.floor(v)
        bu, bv = round((u - iu) * SUBSTEPS), round((v - iv) * SUBSTEPS)
        key = (bu, bv)
        template = self._templates.get(key)
        if template is None:
            template = self._templates[key] = self._template(bu / SUBSTEPS, bv / SUBSTEPS)
        m = self._half_window
        ix0, iy0 = iu - m, iv - m
        ny, nx = self.z_met_m.shape
        if ix0 >= 0 and iy0 >= 0 and ix0 + 2 * m + 2 <= nx and iy0 + 2 * m + 2 <= ny:
            return slice(iy0, iy0 + 2 * m + 2), slice(ix0, ix0 + 2 * m + 2), template + z
        # at the grid edge: clip the window
        jx0, jy0 = max(ix0, 0), max(iy0, 0)
        jx1, jy1 = min(ix0 + 2 * m + 2, nx), min(iy0 + 2 * m + 2, ny)
        if jx1 <= jx0 or jy1 <= jy0:
            return None
        cut = template[jy0 - iy0 : jy1 - iy0, jx0 - ix0 : jx1 - ix0]
        return slice(jy0, jy1), slice(jx0, jx1), cut + z

    def _template(self, fu: float, fv: float) -> np.ndarray:
        """R - sqrt(R² - ρ²) on the window around a tip at cell offset (fu, fv)·h; inf outside the footprint."""
        m = self._half_window
        offsets = self.h * (np.arange(-m, m + 2) - np.array([[fv], [fu]]))  # rows: dy, dx
        rho2 = self.radius**2 - (offsets[0] ** 2)[:, None] - (offsets[1] ** 2)[None, :]
        out = np.full(rho2.shape, np.inf)
        inside = rho2 > 0.0
        out[inside] = self.radius - np.sqrt(rho2[inside])
        return out

    def met_height(self, x: float, y: float) -> tuple[float, float, float]:
        """Met surface at (x, y), bilinear, and its slopes ∂z/∂x, ∂z/∂y (clamped at the grid edge) [m, -]."""
        return _bilinear(self.z_met_m, self.x0, self.y0, self.h, x, y)

    def met_owner(self, x: float, y: float) -> int:
        """Commit that formed the met surface at the grid node nearest (x, y); -1 where still flat or off the grid."""
        ix = int((x - self.x0) / self.h + 0.5)
        iy = int((y - self.y0) / self.h + 0.5)
        ny, nx = self.owner_met.shape
        if 0 <= ix < nx and 0 <= iy < ny and x >= self.x0 and y >= self.y0:
            return int(self.owner_met[iy, ix])
        return -1

    def flush(self) -> None:
        """The tool has left: every commit enters the met surface (it then equals the loaded one)."""
        while self._queue:
            _, i, sy, sx, cap = self._queue.popleft()
            _lower(self.z_met_m, self.owner_met, sy, sx, cap, i)

    def unloaded_z_m(self, k_unload_n_per_m: float) -> np.ndarray:
        """Surface after the tool has left (`flush`): each cell springs back by f_z(owner)/k_unload, never
        above the flat sheet [m], shape (ny, nx).

        Args:
            k_unload_n_per_m: Elastic unloading stiffness of the formed sheet [N/m].
        """
        if not (math.isfinite(k_unload_n_per_m) and k_unload_n_per_m > 0):
            raise InputError(f"k_unload_n_per_m = {k_unload_n_per_m!r}: expected a finite number > 0")
        self.flush()
        formed = self.owner_met >= 0
        recovery = np.zeros_like(self.z_met_m)
        f_z = self.commit_f_z_n if (self._restored is not None or self._track) else np.zeros(1)
        recovery[formed] = np.maximum(f_z[self.owner_met[formed]], 0.0) / k_unload_n_per_m
        return np.minimum(self.z_met_m + recovery, 0.0)


def _lower(z: np.ndarray, owner: np.ndarray, sy: slice, sx: slice, cap: np.ndarray, index: int) -> None:
    """z[sy, sx] <- min(z, cap); the cells lowered take `index` as owner."""
    view = z[sy, sx]
    lower = np.less(cap, view)
    np.copyto(view, cap, where=lower)
    np.copyto(owner[sy, sx], index, where=lower)


def _bilinear(table: np.ndarray, x0: float, y0: float, h: float, x: float, y: float) -> tuple[float, float, float]:
    """Bilinear value of table[iy, ix] at (x, y) on the grid (x0 + h·ix, y0 + h·iy), and its two slopes."""
    ny, nx = table.shape
    u = min(max((x - x0) / h, 0.0), nx - 1.000000001)
    v = min(max((y - y0) / h, 0.0), ny - 1.000000001)
    i, j = int(u), int(v)
    fu, fv = u - i, v - j
    a, b = float(table[j, i]), float(table[j, i + 1])
    c, d = float(table[j + 1, i]), float(table[j + 1, i + 1])
    value = (a * (1 - fu) + b * fu) * (1 - fv) + (c * (1 - fu) + d * fu) * fv
    slope_x = ((b - a) * (1 - fv) + (d - c) * fv) / h
    slope_y = ((c - a) * (1 - fu) + (d - b) * fu) / h
    return value, slope_x, slope_y
