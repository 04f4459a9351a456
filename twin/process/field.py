"""A stateful force field of the sheet, fitted to an FE force history.

The history gives the force along the IDEAL path with a rigid machine. A compliant robot leaves the ideal
path, so the twin needs the force at other tool positions, and that force depends on what earlier passes
formed. The model (all lengths in the sheet frame, along the groove centre line y = 0):

* State: `formed_z_m(x)`, the loaded groove-bottom profile, the lower envelope of the tool sphere over every
  committed position (`advance`): formed_z(x) = min(formed_z(x), z_t + R - sqrt(R² - (x - x_t)²)) for
  |x - x_t| < R, R = 7.5 mm (§2.2); initially 0 (flat sheet). Also the current pass and a snapshot of the
  profile taken when that pass started: the surface the tool meets ahead of it.
* Reference depth: δ = z_ref(x) - z_tool, with z_ref the profile formed before the queried pass started
  (the snapshot when `pass_index` is the current pass, else the profile formed so far). δ_plan(x, pass) is
  the same quantity for the ideal path, computed at construction by driving the history's own samples.
* Vertical force: Fz = softplus(Fz_hist(x, pass) + k·(δ - δ_plan)), k = k_unload when the tool is above plan
  (δ < δ_plan), k_load below. Fz_hist is a per-pass PCHIP fit of the history over x (tabulated on a 0.1 mm
  grid). The softplus (width 5 N) keeps Fz >= 0 and smooth: the force falls to zero once the tool has risen
  Fz_hist/k_unload above plan, i.e. above the loaded formed surface by the sheet's elastic recovery.
* Fx = (Fx_hist/Fz_hist)·Fz, with the sign of the travel direction; Fy = 0 (symmetry, §2.2).

Sensitivities (dFz/dz = -k):

* k_unload = 1.3 kN/mm: elastic unloading of the formed sheet. Thesis §2.3.1: the groove formed to 10 mm
  recovers to 8.7 mm when the tool (≈ 1.7 kN at the last pass) leaves, so 1.7 kN / 1.3 mm ≈ 1.3 kN/mm.
* k_load = 0.15 kN/mm: pressing deeper is plastic; Aerens et al. (CIRP Annals 2010) give Fz ∝ Δh^0.09, so
  dFz/dΔh ≈ 0.09·Fz/Δh = 0.09·1.7 kN / 1 mm ≈ 0.15 kN/mm.

Why the snapshot reference: a steady offset of the tool over every pass leaves δ = δ_plan from pass 2 on
(the groove is shallower, the force is as planned), while on pass 1 (flat sheet) it changes the force by
k·offset. With `stateful=False` the reference is always the ideal profile: Fz = Fz_hist + k·(z_plan - z).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PchipInterpolator

from twin.errors import InputError
from twin.process.forces import ForceHistory
from twin.process.path import ToolPath, label_passes

#: Elastic unloading stiffness of the formed sheet [N/m] (1.7 kN over 1.3 mm springback, §2.3.1).
K_UNLOAD_N_PER_M = 1.3e6
#: Plastic loading sensitivity [N/m] (Aerens 2010: 0.09·Fz/Δh with Fz = 1.7 kN, Δh = 1 mm).
K_LOAD_N_PER_M = 0.15e6
#: Tool radius R_T [m] (§2.2, Table 2.2).
TOOL_RADIUS_M = 7.5e-3
#: Half-width of the modelled sheet along x [m] (FE sheet 240 mm, §2.2).
SHEET_HALF_LENGTH_M = 0.120
_SOFTPLUS_N = 5.0


@dataclass(frozen=True)
class _PassTable:
    x0: float
    dx: float
    n: int
    fz: np.ndarray
    ratio: np.ndarray
    z_plan: np.ndarray
    delta_plan: np.ndarray
    direction: int


def _lerp(table: np.ndarray, x0: float, dx: float, n: int, x: float) -> float:
    u = (x - x0) / dx
    if u <= 0.0:
        return float(table[0])
    if u >= n - 1:
        return float(table[n - 1])
    i = int(u)
    f = u - i
    return float(table[i] * (1.0 - f) + table[i + 1] * f)


def _lerp_slope(table: np.ndarray, x0: float, dx: float, n: int, x: float) -> tuple[float, float]:
    """`_lerp` (same arithmetic) and its slope d/dx (0 where the table is clamped) [table unit / m]."""
    u = (x - x0) / dx
    if u <= 0.0:
        return float(table[0]), 0.0
    if u >= n - 1:
        return float(table[n - 1]), 0.0
    i = int(u)
    f = u - i
    a, b = float(table[i]), float(table[i + 1])
    return a * (1.0 - f) + b * f, (b - a) / dx


class SheetForceField:
    """Force exerted by the sheet on the tool as a function of tool position, pass and forming history."""

    def __init__(
        self,
        history: ForceHistory,
        *,
        k_unload_n_per_m: float = K_UNLOAD_N_PER_M,
        k_load_n_per_m: float = K_LOAD_N_PER_M,
        tool_radius_m: float = TOOL_RADIUS_M,
        grid_step_m: float = 1e-4,
        stateful: bool = True,
        deadband_m: float = 1e-6,
    ) -> None:
        """Fit the field to a history.

        Args:
            history: Physical force history along the ideal path (`load_force_history`).
            k_unload_n_per_m: dFz/d(height above plan) while the tool is above plan [N/m].
            k_load_n_per_m: dFz/d(depth below plan) while the tool is below plan [N/m].
            tool_radius_m: Tool sphere radius [m].
            grid_step_m: Spacing of the profile grid and of the per-pass tables [m].
            stateful: False: the reference surface is always the ideal one (no forming history).
            deadband_m: Dead band for labelling the history's passes (`label_passes`) [m].
        """
        for name, value in (
            ("k_unload_n_per_m", k_unload_n_per_m),
            ("k_load_n_per_m", k_load_n_per_m),
            ("tool_radius_m", tool_radius_m),
            ("grid_step_m", grid_step_m),
        ):
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"{name} = {value!r}: expected a finite number > 0")
        self.k_unload = float(k_unload_n_per_m)
        self.k_load = float(k_load_n_per_m)
        self.radius = float(tool_radius_m)
        self.stateful = stateful
        self._dx = float(grid_step_m)
        n_grid = round(2 * SHEET_HALF_LENGTH_M / self._dx) + 1
        self._x0 = -SHEET_HALF_LENGTH_M
        self.x_grid_m = self._x0 + self._dx * np.arange(n_grid)
        self._n_grid = n_grid
        self._formed = np.zeros(n_grid)
        self._snapshot = self._formed.copy()
        self._pass = 0
        self._hyst: tuple[float, float, int] | None = None  # (start x, extreme x, direction) for inference

        x, z = history.p_sheet_m[:, 0], history.p_sheet_m[:, 2]
        fx, fz = history.f_sheet_n[:, 0], history.f_sheet_n[:, 2]
        pass_index, direction = label_passes(x, deadband_m=deadband_m)
        self.n_passes = int(pass_index.max())
        tables: list[_PassTable] = []
        for j in range(1, self.n_passes + 1):
            sel = np.flatnonzero(pass_index == j)
            xs, order = np.unique(x[sel], return_index=True)
            if len(xs) < 2:
                raise InputError(f"{history.source}: pass {j} has fewer than 2 distinct x samples")
            sel = sel[order]
            n = max(2, math.ceil((xs[-1] - xs[0]) / self._dx) + 1)
            grid = np.linspace(xs[0], xs[-1], n)
            fz_t = PchipInterpolator(xs, fz[sel])(grid)
            fx_t = PchipInterpolator(xs, fx[sel])(grid)
            # reference drive of the ideal path: profile before pass j, then commit pass j's samples
            self._snapshot = self._formed.copy()
            z_plan = np.interp(grid, xs, z[sel])
            delta_plan = np.interp(grid, self.x_grid_m, self._snapshot) - z_plan
            for i in np.flatnonzero(pass_index == j):
                self._commit(float(x[i]), float(z[i]))
            tables.append(
                _PassTable(
                    x0=float(grid[0]),
                    dx=float(grid[1] - grid[0]),
                    n=n,
                    fz=fz_t,
                    ratio=fx_t / np.maximum(fz_t, 1.0),
                    z_plan=z_plan,
                    delta_plan=delta_plan,
                    direction=int(direction[sel[0]]),
                )
            )
        self._tables = tables
        self._plan_profile = self._formed.copy()
        self.reset()

    # ---------------------------------------------------------------- state
    def reset(self) -> None:
        """Back to a flat, unformed sheet before pass 1."""
        self._formed = np.zeros(self._n_grid)
        self._snapshot = self._formed.copy()
        self._pass = 0
        self._hyst = None

    @property
    def formed_z_m(self) -> np.ndarray:
        """Loaded groove-bottom profile formed so far on `x_grid_m` [m] (a copy)."""
        return self._formed.copy()

    @property
    def current_pass(self) -> int:
        """Pass of the last committed sample (0 before any)."""
        return self._pass

    def _commit(self, x: float, z: float) -> None:
        r = self.radius
        i0 = max(0, math.ceil((x - r - self._x0) / self._dx))
        i1 = min(self._n_grid, math.floor((x + r - self._x0) / self._dx) + 1)
        if i1 <= i0:
            return
        cap = self.x_grid_m[i0:i1] - x  # in place below: z + r - sqrt(max(r² - dx², 0)), ~2x faster
        np.multiply(cap, cap, out=cap)
        np.subtract(r * r, cap, out=cap)
        np.maximum(cap, 0.0, out=cap)
        np.sqrt(cap, out=cap)
        np.subtract(z + r, cap, out=cap)
        formed = self._formed[i0:i1]
        np.minimum(formed, cap, out=formed)

    def advance(self, p_sheet_m: np.ndarray, pass_index: int | None = None) -> None:
        """Commit: the tool tip passed through `p_sheet_m`; the formed profile under the sphere is updated.

        Args:
            p_sheet_m: Tool-tip position in the sheet frame [m], shape (3,).
            pass_index: Pass of this sample; None infers passes from x reversals (dead band 1 µm).
        """
        x, z = float(p_sheet_m[0]), float(p_sheet_m[2])
        if pass_index is None:
            pass_index = self._infer_pass(x)
        if pass_index != self._pass:
            if pass_index < self._pass:
                raise InputError(
                    f"pass_index {pass_index} is before the current pass {self._pass}; call reset()"
                )
            self._snapshot = self._formed.copy()
            self._pass = pass_index
        self._commit(x, z)

    def _infer_pass(self, x: float, deadband: float = 1e-6) -> int:
        if self._hyst is None:
            self._hyst = (x, x, 0)
            return max(self._pass, 1)
        start, ext, d = self._hyst
        current = max(self._pass, 1)
        if d == 0:
            if abs(x - start) > deadband:
                self._hyst = (start, x, 1 if x > start else -1)
        elif d * (x - ext) > 0.0:
            self._hyst = (start, x, d)
        elif d * (ext - x) > deadband:
            self._hyst = (start, x, -d)
            return current + 1
        return current

    # ---------------------------------------------------------------- force
    def _table(self, pass_index: int) -> _PassTable:
        if not 1 <= pass_index <= self.n_passes:
            raise InputError(f"pass_index = {pass_index!r}: the history has passes 1..{self.n_passes}")
        return self._tables[pass_index - 1]

    def _fz_lin(self, x: float, z: float, pass_index: int) -> tuple[float, float, float, float]:
        """(linear Fz, Fz_hist, Fx/Fz ratio, k in effect) at (x, z)."""
        t = self._table(pass_index)
        fz_h = _lerp(t.fz, t.x0, t.dx, t.n, x)
        if self.stateful:
            ref = self._snapshot if pass_index == self._pass else self._formed
            delta = _lerp(ref, self._x0, self._dx, self._n_grid, x) - z
            err = delta - _lerp(t.delta_plan, t.x0, t.dx, t.n, x)
        else:
            err = _lerp(t.z_plan, t.x0, t.dx, t.n, x) - z
        k = self.k_load if err > 0.0 else self.k_unload
        return fz_h + k * err, fz_h, _lerp(t.ratio, t.x0, t.dx, t.n, x), k

    def _evaluate(self, x: float, z: float, pass_index: int, direction: int) -> tuple[float, ...]:
        """Force and its analytic gradient at (x, z), with `force`'s arithmetic.

        Returns:
            (Fx, Fz, dFx/dx, dFx/dz, dFz/dx, dFz/dz) [N, N/m]. Within a grid cell the tables are linear in x,
            so the gradient is exact there; on a grid node it is the slope of the cell to the right, and on the
            k_load/k_unload switch (error exactly 0) it uses k_unload, as `force` does.
        """
        if direction != 1 and direction != -1:
            raise InputError(f"direction = {direction!r}: expected +1 or -1")
        t = self._table(pass_index)
        fz_h, dfz_h = _lerp_slope(t.fz, t.x0, t.dx, t.n, x)
        if self.stateful:
            ref = self._snapshot if pass_index == self._pass else self._formed
            z_ref, dz_ref = _lerp_slope(ref, self._x0, self._dx, self._n_grid, x)
            plan, dplan = _lerp_slope(t.delta_plan, t.x0, t.dx, t.n, x)
            err = (z_ref - z) - plan
            derr = dz_ref - dplan
        else:
            z_plan, derr = _lerp_slope(t.z_plan, t.x0, t.dx, t.n, x)
            err = z_plan - z
        k = self.k_load if err > 0.0 else self.k_unload
        lin = fz_h + k * err
        w = _SOFTPLUS_N
        if lin > 30.0 * w:
            fz, slope = lin, 1.0
        else:
            e = math.exp(lin / w)
            fz, slope = w * math.log1p(e), e / (1.0 + e)
        ratio, dratio = _lerp_slope(t.ratio, t.x0, t.dx, t.n, x)
        sign = 1.0 if direction * t.direction > 0 else -1.0
        dfz_dx, dfz_dz = slope * (dfz_h + k * derr), -slope * k
        return (
            sign * ratio * fz,
            fz,
            sign * (dratio * fz + ratio * dfz_dx),
            sign * ratio * dfz_dz,
            dfz_dx,
            dfz_dz,
        )

    def force(self, p_sheet_m: np.ndarray, pass_index: int, direction: int) -> np.ndarray:
        """Force exerted by the sheet on the tool [N], sheet frame; pure (the state is not changed).

        Args:
            p_sheet_m: Tool-tip position in the sheet frame [m], shape (3,).
            pass_index: Pass 1..N of the history the tool is in.
            direction: Travel direction along x, +1 or -1.

        Returns:
            (Fx, Fy, Fz) [N]; Fz >= 0, Fy = 0.
        """
        if direction != 1 and direction != -1:
            raise InputError(f"direction = {direction!r}: expected +1 or -1")
        x, z = float(p_sheet_m[0]), float(p_sheet_m[2])
        lin, _, ratio, _ = self._fz_lin(x, z, pass_index)
        w = _SOFTPLUS_N
        fz = lin if lin > 30.0 * w else w * math.log1p(math.exp(lin / w))
        sign = 1.0 if direction * self._tables[pass_index - 1].direction > 0 else -1.0
        return np.array([sign * ratio * fz, 0.0, fz])

    def force_and_stiffness(
        self, p_sheet_m: np.ndarray, pass_index: int, direction: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """`force` and the analytic `stiffness` in one evaluation (the twin's Newton loop needs both).

        Args:
            p_sheet_m: Tool-tip position in the sheet frame [m], shape (3,).
            pass_index: Pass 1..N of the history.
            direction: Travel direction along x, +1 or -1.

        Returns:
            Force [N], shape (3,), and ∂f/∂p [N/m], shape (3, 3).
        """
        fx, fz, fx_x, fx_z, fz_x, fz_z = self._evaluate(float(p_sheet_m[0]), float(p_sheet_m[2]), pass_index, direction)
        return np.array([fx, 0.0, fz]), np.array([[fx_x, 0.0, fx_z], [0.0, 0.0, 0.0], [fz_x, 0.0, fz_z]])

    def stiffness(
        self, p_sheet_m: np.ndarray, pass_index: int, direction: int, *, step_m: float | None = None
    ) -> np.ndarray:
        """∂f/∂p [N/m], shape (3, 3) (the force does not depend on y).

        Analytic by default (the field is piecewise linear in x and z under a softplus); with `step_m`, by
        central differences as before. The two agree to ~1e-9 relative inside a grid cell; on a 0.1 mm grid
        node or the load/unload switch the analytic one takes one side, the central difference averages.

        Args:
            p_sheet_m: Tool-tip position in the sheet frame [m].
            pass_index: Pass of the history.
            direction: Travel direction, +1 or -1.
            step_m: Finite-difference step [m]; None for the analytic derivative.
        """
        p = np.asarray(p_sheet_m, dtype=float)
        if step_m is None:
            return self.force_and_stiffness(p, pass_index, direction)[1]
        jac = np.zeros((3, 3))
        for j in (0, 2):
            e = np.zeros(3)
            e[j] = step_m
            jac[:, j] = (
                self.force(p + e, pass_index, direction) - self.force(p - e, pass_index, direction)
            ) / (2 * step_m)
        return jac

    def rigid_forces(self, path: ToolPath) -> np.ndarray:
        """Reset, then drive the field along `path` with a rigid robot: force at each sample, then advance.

        Args:
            path: Path with pass labels (within the history's passes).

        Returns:
            Forces exerted by the sheet on the tool [N], shape (n, 3).
        """
        self.reset()
        out = np.empty((len(path), 3))
        passes = [int(v) for v in path.pass_index]
        dirs = [int(v) for v in path.direction]
        for i, p in enumerate(path.p_sheet_m):
            out[i] = self.force(p, passes[i], dirs[i])
            self.advance(p, passes[i])
        return out

    def part_profile(self, springback_ratio: float = 0.87) -> tuple[np.ndarray, np.ndarray]:
        """Profile of the part after unloading: the formed depth scaled by `springback_ratio`.

        A uniform depth ratio is the simplest reading of §2.3.1 (8.7 mm formed of the 10 mm target).

        Args:
            springback_ratio: Remaining fraction of the loaded depth, in (0, 1].

        Returns:
            (x_m, z_m) on the profile grid [m].
        """
        if not 0.0 < springback_ratio <= 1.0:
            raise InputError(f"springback_ratio = {springback_ratio!r}: expected a value in (0, 1]")
        return self.x_grid_m.copy(), self._formed * springback_ratio
