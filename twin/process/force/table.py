"""A stateful force field of the sheet, fitted to an FE force history.

The history gives the force along the IDEAL path with a rigid machine. A compliant robot leaves the ideal
path, so the twin needs the force at other tool positions, and that force depends on what earlier passes
formed. The model (all lengths in the sheet frame, along the groove centre line y = 0):

* State: `formed_z_m(x)`, the loaded groove-bottom profile, the lower envelope of the tool sphere over every
  committed position (`advance`; `twin.process.part.formed_profile`), initially 0 (flat sheet); the current pass
  and a snapshot of the profile taken when that pass started: the surface the tool meets ahead of it.
* Reference depth: δ = z_ref(x) - z_tool, with z_ref the profile formed before the queried pass started
  (the snapshot when `pass_index` is the current pass, else the profile formed so far). δ_plan(x, pass) is
  the same quantity for the ideal path, computed at construction by driving the history's own samples.
* Vertical force, two regimes of the depth δ below the surface the tool meets (Fz_hist(x, pass) is a
  per-pass PCHIP fit of the history over x, tabulated on a 0.1 mm grid):
  - δ > 0, forming: the tool is still below that surface and deforms the sheet plastically, and the force
    depends only weakly on the step-down (Aerens et al., Int J Adv Manuf Technol 46 (2010): Fz ∝ Δh^0.09 with
    Δh the scallop height, about Δz^0.18 on a wall of fixed angle):
    Fz = Fz_hist + k_load·(δ - δ_plan), on both sides of the plan;
  - δ <= 0, lifted: the tool has risen above that surface and the sheet unloads elastically:
    Fz = Fz_hist - k_load·δ_plan + k_unload·δ (continuous at δ = 0), falling to zero within
    (Fz_hist - k_load·δ_plan)/k_unload, i.e. by the sheet's elastic recovery.
  A softplus (width 5 N) keeps Fz >= 0 and smooth. With `stateful=False` the switch is at the plan:
  Fz = Fz_hist + k·(z_plan - z), k = k_load below plan and k_unload above it.
* Fx = (Fx_hist/Fz_hist)·Fz, with the sign of the travel direction; Fy = 0 (symmetry, §2.2).

Sensitivities (dFz/dz = -k; calibrated, see `twin.analysis.calibrate` and models/README.md):

* k_unload: elastic unloading of the formed sheet. It also sets the springback of the part when the tool
  leaves (`twin.process.part.springback`): the thesis's CNC test formed 8.7 mm of the 10 mm target (§2.3.1).
* k_load: pressing deeper or shallower while forming; the prior reads Aerens's exponent 0.09 on the step-down,
  dFz/dΔz ≈ 0.09·Fz/Δz = 0.09·1.7 kN / 1 mm ≈ 0.15 kN/mm (with the scallop height as published, twice that on
  a wall of fixed angle; the calibration fits k_load to the thesis's tests, models/README.md).

Why not switch to k_unload as soon as the tool is above *plan*: a robot that gives way by a fraction of the
step-down would then lose force at 1.3 kN/mm, and Method 2 with ideal forces would read 35 % stiffer than the
robot, against the thesis, where Method 2 read as compliant as Method 1 (§4.2.3).

Why the snapshot reference: a steady offset of the tool over every pass leaves δ = δ_plan from pass 2 on
(the groove is shallower, the force is as planned), while on pass 1 (flat sheet) it changes the force by
k·offset. With `stateful=False` the reference is always the ideal profile: Fz = Fz_hist + k·(z_plan - z).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twin.errors import InputError
from twin.process.fe.load import ForceHistory
from twin.process.force.base import FieldState, ForceField
from twin.process.force.pass_tables import PassTable, shared_pass_tables
from twin.process.force.pass_tables import lerp as _lerp
from twin.process.force.pass_tables import lerp_slope as _lerp_slope
from twin.process.force.pass_tables import lerp_slope3 as _lerp_slope3
from twin.process.part.formed_profile import FormedProfile

#: Elastic unloading stiffness of the formed sheet [N/m]: calibrated (`tx200-twin calibrate`) to the CNC test's
#: springback, 8.7 mm formed of the 10 mm target (§2.3.1), 1.43 ± 0.29 kN/mm.
K_UNLOAD_N_PER_M = 1.429e+06
#: Forming sensitivity [N/m]: calibrated with Aerens's 0.09·Fz/Δh ≈ 0.15 kN/mm as a prior, 0.160 ± 0.065 kN/mm.
K_LOAD_N_PER_M = 1.596e+05
#: Tool radius R_T [m] (§2.2, Table 2.2).
TOOL_RADIUS_M = 7.5e-3
#: Half-width of the modelled sheet along x [m] (FE sheet 240 mm, §2.2).
SHEET_HALF_LENGTH_M = 0.120
#: Width of the softplus that keeps Fz >= 0 and smooth [N].
SOFTPLUS_N = 5.0


@dataclass(frozen=True)
class TableState(FieldState):
    """Scalar state of the table field: the pass of the last committed sample (0 before any)."""

    current_pass: int


class SheetForceField(ForceField):
    """Force exerted by the sheet on the tool as a function of tool position, pass and forming history.

    Declares the compiled kernel `table`; its Fx flips with the commanded direction (the twin wraps it in the
    tool's sliding friction) and its force steps from pass to pass (`twin.process.force.base`).
    """

    compiled_kernel = "table"
    tangential_from_command = True
    steps_between_passes = True

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
        tables: list[PassTable] | None = None,
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
            tables: The history's pass tables when already built (`pass_tables`, `scaled_tables`): no refit.
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
        self._profile = p = FormedProfile(self.radius, grid_step_m, SHEET_HALF_LENGTH_M)
        self._x0, self._dx, self._n_grid = p.x0, p.dx, p.n
        self._formed, self._snapshot = p.z_m, p.snapshot_m  # never rebound: the hot path reads them directly
        self._pass = 0
        self._hyst: tuple[float, float, int] | None = None  # (start x, extreme x, direction) for inference
        self._tables = tables if tables is not None else shared_pass_tables(
            history, self.radius, grid_step_m, SHEET_HALF_LENGTH_M, deadband_m=deadband_m)
        self.n_passes = len(self._tables)
        self.reset()

    # ---------------------------------------------------------------- state
    def reset(self) -> None:
        """Back to a flat, unformed sheet before pass 1."""
        self._profile.reset()
        self._pass = 0
        self._hyst = None

    @property
    def pass_tables(self) -> list[PassTable]:
        """The history's per-pass tables (shared, never changed)."""
        return self._tables

    @property
    def x_grid_m(self) -> np.ndarray:
        """Abscissae of the formed profile [m]."""
        return self._profile.x_grid_m

    @property
    def formed_z_m(self) -> np.ndarray:
        """Loaded groove-bottom profile formed so far on `x_grid_m` [m] (a copy)."""
        return self._formed.copy()

    @property
    def state(self) -> TableState:
        """The pass of the last committed sample."""
        return TableState(self._pass)

    def restore(self, state: FieldState) -> None:
        """Set the current pass (a loop that advanced `profile` itself)."""
        if not isinstance(state, TableState):
            raise InputError(f"state {state!r} is not a TableState")
        self._pass = int(state.current_pass)

    @property
    def current_pass(self) -> int:
        """Pass of the last committed sample (0 before any)."""
        return self._pass

    @property
    def profile(self) -> FormedProfile:
        """The formed profile and its snapshot (changed in place by `advance`)."""
        return self._profile

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
            self._profile.take_snapshot()
            self._pass = pass_index
        self._profile.commit(x, z)

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
    def _table(self, pass_index: int) -> PassTable:
        if not 1 <= pass_index <= self.n_passes:
            raise InputError(f"pass_index = {pass_index!r}: the history has passes 1..{self.n_passes}")
        return self._tables[pass_index - 1]

    def _fz_lin(self, x: float, z: float, pass_index: int) -> tuple[float, float, float, float]:
        """(linear Fz, Fz_hist, Fx/Fz ratio, k in effect) at (x, z)."""
        t = self._table(pass_index)
        fz_h = _lerp(t.fz, t.x0, t.dx, t.n, x)
        ratio = _lerp(t.ratio, t.x0, t.dx, t.n, x)
        if self.stateful:
            ref = self._snapshot if pass_index == self._pass else self._formed
            delta = _lerp(ref, self._x0, self._dx, self._n_grid, x) - z
            plan = _lerp(t.delta_plan, t.x0, t.dx, t.n, x)
            if delta > 0.0:  # still below the surface it meets: plastic forming, Aerens' weak sensitivity
                return fz_h + self.k_load * (delta - plan), fz_h, ratio, self.k_load
            return fz_h - self.k_load * plan + self.k_unload * delta, fz_h, ratio, self.k_unload
        err = _lerp(t.z_plan, t.x0, t.dx, t.n, x) - z
        k = self.k_load if err > 0.0 else self.k_unload
        return fz_h + k * err, fz_h, ratio, k

    def _evaluate(self, x: float, z: float, pass_index: int, direction: int) -> tuple[float, ...]:
        """Force and its analytic gradient at (x, z), with `force`'s arithmetic.

        Returns:
            (Fx, Fz, dFx/dx, dFx/dz, dFz/dx, dFz/dz) [N, N/m]. Within a grid cell the tables are linear in x,
            so the gradient is exact there; on a grid node it is the slope of the cell to the right, and on the
            forming/lifted switch (δ exactly 0) it uses k_unload, as `force` does.
        """
        if direction != 1 and direction != -1:
            raise InputError(f"direction = {direction!r}: expected +1 or -1")
        t = self._table(pass_index)
        fz_h, dfz_h, ratio, dratio, plan, dplan = _lerp_slope3(
            t.fz, t.ratio, t.delta_plan if self.stateful else t.z_plan, t.x0, t.dx, t.n, x
        )
        if self.stateful:
            ref = self._snapshot if pass_index == self._pass else self._formed
            z_ref, dz_ref = _lerp_slope(ref, self._x0, self._dx, self._n_grid, x)
            delta = z_ref - z
            if delta > 0.0:
                k = self.k_load
                lin, dlin_dx = fz_h + k * (delta - plan), dfz_h + k * (dz_ref - dplan)
            else:
                k = self.k_unload
                lin = fz_h - self.k_load * plan + k * delta
                dlin_dx = dfz_h - self.k_load * dplan + k * dz_ref
        else:  # plan, dplan: z_plan and its slope
            err = plan - z
            k = self.k_load if err > 0.0 else self.k_unload
            lin, dlin_dx = fz_h + k * err, dfz_h + k * dplan
        w = SOFTPLUS_N
        if lin > 30.0 * w:
            fz, slope = lin, 1.0
        else:
            e = math.exp(lin / w)
            fz, slope = w * math.log1p(e), e / (1.0 + e)
        sign = 1.0 if direction * t.direction > 0 else -1.0
        dfz_dx, dfz_dz = slope * dlin_dx, -slope * k
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
        w = SOFTPLUS_N
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

    def stiffness(self, p_sheet_m: np.ndarray, pass_index: int, direction: int) -> np.ndarray:
        """∂f/∂p [N/m], shape (3, 3), analytic (the field is piecewise linear in x and z under a softplus; the
        force does not depend on y): `force_and_stiffness`'s gradient."""
        return self.force_and_stiffness(np.asarray(p_sheet_m, dtype=float), pass_index, direction)[1]
