"""A general ISF force model on the formed-surface height map: the force on the tool for any part and path.

State: `twin.process.part.heightmap.HeightMap` (2-D, 0.5 mm grid, lower envelope of the tool sphere, elastic
recovery), driven by `advance`. At a tool-tip position p = (x, y, z) in the sheet frame, from the *met* surface
S (the surface formed before the tool got here):

* engagement Δz = S(x, y) - z, the depth of the tool tip below the surface it meets: on a wall formed contour
  by contour, the step-down [mm];
* local wall angle α, from the layers above the tool: the met cell under the tip was formed by an earlier tool
  position (its owner), the cell under that one by another, and so on; walking up until the layer reached lies
  1 mm above the tip, α = atan2(rise, horizontal run) to it (a cone's previous revolutions, for instance), capped
  at α_max, the groove's end walls (63.43°, `docs/forces.md`): a step straight down, as in the zig-zag groove,
  is no cone wall. The model holds α and moves it towards each reading over 10 mm of travel (a wall angle
  changes slowly along a part; single readings jump with the path's sampling and with the tool's deflection),
  starting at α_max (first contact) and keeping it over sheet never formed. The horizontal direction n from the
  tip to that layer is the wall the tool presses (outwards on a cone);
* forming (Δz > Δz_min): Aerens et al.'s steady-state axial force with the scallop height of the engagement
  (`twin.process.force.aerens`: IJAMT 46, 2010, Eq. 30) times a build-up with depth,

      Fz = 0.0716 · R_m · t^1.57 · d_t^0.41 · h(Δz, α)^0.09 · α · cos α · B(D)      [N; MPa, mm, deg]

  h = R - sqrt(R² - (Δz / (2 sin α))²), B(D) = 1 - exp(-D/D0) over the depth D = -z below the original sheet
  (published SPIF forces rise over the first millimetres of depth to a plateau; D0 in `IsfForceParams`);
* a shallow engagement 0 <= Δz <= Δz_min: the plateau Fz(Δz_min) (h^0.09 is singular at 0: its stiffness would
  grow without bound; Δz_min caps it);
* elastic (Δz < 0, the tool has risen from the surface it meets): Fz(Δz_min) + k_unload·Δz, continuous,
  falling to zero by the sheet's elastic recovery; a softplus (5 N) keeps Fz >= 0 and smooth;
* in-plane force, two parts: tangential, against the sliding, -μ_t·Fz·v, v the sliding direction implicit in
  the queried position (`twin.process.force.sliding`: it turns over L_f of travel, |v| = 1 on a straight run; a tool
  that reverses leaves the wall it was pushing, so v is released over 0.05 mm and the force builds up against
  the new travel as 1 - exp(-u/L_f)); radial, across the travel away from the wall, -μ_r·Fz·σ·L·v, L the
  quarter turn to the left and σ the held side of the wall (+1 left of the travel, -1 right: the part of n
  across the travel, filtered like α, so the radial force turns with the travel around a part). A step straight
  down, or a wall along the travel (the groove), has no radial part.

Material and tool come from the process (R_m, t, R); the default is the thesis's AA5086-H111, 1 mm, Ø 15 mm.
The stiffness ∂f/∂p is analytic (h^0.09, the build-up, the slope of the met surface, the implicit sliding
direction); α and n are state and not differentiated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from twin.errors import InputError
from twin.process.force.aerens import EXPONENT_SCALLOP, scallop_height_m
from twin.process.force.base import FieldState, ForceField
from twin.process.force.isf_params import IsfForceParams, material_fz_n
from twin.process.force.sliding import RELEASE_LENGTH_M, sliding_direction
from twin.process.force.table import SOFTPLUS_N
from twin.process.part.heightmap import HeightMap

_SOFTPLUS_N = SOFTPLUS_N
#: Height over which the wall angle is read from the layers above the tool [m], and the most layers walked.
WALL_BASELINE_M = 1.0e-3
WALL_MAX_LAYERS = 12
#: Horizontal run to the layer above under which the wall has no direction (a step straight down) [m].
WALL_RUN_MIN_M = 0.1e-3
#: Travel over which the held wall angle follows its readings [m] (0: jump to each reading).
ALPHA_LENGTH_M = 10e-3


@dataclass(frozen=True)
class IsfMotion(FieldState):
    """The ISF model's scalar state besides its height map.

    Attributes:
        direction: Held sliding direction (vx, vy) [-].
        last_tip_m: Last committed tool tip (x, y, z) [m], or None before the first.
        wall_angle_deg: Held wall angle [deg].
        last_step_m: Length of the last committed step [m].
        wall_side: Held side of the wall above the tip, across the travel [-]: +1 to the left of the travel,
            -1 to the right, 0 where none was read (a step straight down, a wall along the travel).
    """

    direction: tuple[float, float]
    last_tip_m: tuple[float, float, float] | None
    wall_angle_deg: float
    last_step_m: float
    wall_side: float = 0.0


class IsfForceField(ForceField):
    """Force of the sheet on the tool at any tool position, on the height map (a `ForceField`, compiled kernel
    `isf`).

    `pass_index` and `direction` are accepted for the interface and ignored: the model needs no pass labels, and
    its in-plane force follows the tool's own travel.

    Args:
        params: Model constants; None for the calibrated defaults.
        half_size_m: Half-extent (x, y) of the modelled sheet [m].
    """

    compiled_kernel: ClassVar[str | None] = "isf"
    extrapolated_start = True

    def __init__(self, params: IsfForceParams | None = None, half_size_m: tuple[float, float] = (0.12, 0.12)) -> None:
        self.params = p = params or IsfForceParams()
        self.map = HeightMap(p.tool_radius_m, p.spacing_m, half_size_m)
        self.radius = p.tool_radius_m
        self.k_unload = p.k_unload_n_per_m
        self._amax = p.wall_angle_max_deg
        self._base = material_fz_n(p)
        self._dir = (0.0, 0.0)
        self._last: tuple[float, float, float] | None = None
        self._alpha = self._amax
        self._side = 0.0
        self._last_fz = ((math.nan, math.nan, math.nan), 0.0)
        self.reset()
        self.k_load = self._fz_of(1e-3, self._amax, 1.0)[1]  # dFz/dΔz at 1 mm on α_max, built up, for reports

    def reset(self) -> None:
        """Back to a flat, unformed sheet."""
        self.map.reset()
        self._dir = (0.0, 0.0)
        self._last = None
        self._alpha = self._amax
        self._side = 0.0
        self._last_step = 0.0
        self._last_fz = ((math.nan, math.nan, math.nan), 0.0)

    @property
    def base_fz_n(self) -> float:
        """Fz / (h_mm^0.09 · α · cos α) of the params' material, tool and scale [N] (`material_fz_n`)."""
        return self._base

    @property
    def state(self) -> IsfMotion:
        """Sliding direction, last committed tip, held wall angle, last step and held wall side."""
        return IsfMotion(self._dir, self._last, self._alpha, self._last_step, self._side)

    def restore(self, state: FieldState) -> None:
        """Set the motion state (a loop that advanced the map itself, the compiled replay)."""
        if not isinstance(state, IsfMotion):
            raise InputError(f"state {state!r} is not an IsfMotion")
        self._dir, self._last, self._alpha, self._last_step, self._side = (
            state.direction, state.last_tip_m, state.wall_angle_deg, state.last_step_m, state.wall_side
        )
        self._last_fz = ((math.nan, math.nan, math.nan), 0.0)

    @property
    def height_map(self) -> HeightMap:
        """The 2-D formed surface."""
        return self.map

    @property
    def x_grid_m(self) -> np.ndarray:
        """Abscissae of the `formed_z_m` section [m]."""
        return self.map.x_m

    @property
    def formed_z_m(self) -> np.ndarray:
        """Loaded formed surface along the section y = 0 [m] (a copy; the 2-D map is `self.map`)."""
        row = min(max(round(-self.map.y0 / self.map.h), 0), len(self.map.y_m) - 1)
        return self.map.z_loaded_m[row].copy()

    def advance(self, p_sheet_m: np.ndarray, pass_index: int | None = None, f_z_n: float | None = None) -> None:
        """Commit: the tool tip passed through `p_sheet_m`; update the map, the travel direction, the wall angle.

        Args:
            p_sheet_m: Tool-tip position (3,) [m].
            pass_index: Ignored (interface of `SheetForceField`).
            f_z_n: Vertical force there, for the elastic recovery [N]; None: the last `force` at this point,
                else the model's.
        """
        x, y, z = float(p_sheet_m[0]), float(p_sheet_m[1]), float(p_sheet_m[2])
        if f_z_n is None:
            f_z_n = self._last_fz[1] if self._last_fz[0] == (x, y, z) else self._fz(x, y, z)[0]
        vx, vy, _ = self._travel(x, y, jacobian=False)
        self._dir = (vx, vy)
        self._last_step = 0.0 if self._last is None else math.dist(self._last, (x, y, z))
        self._last = (x, y, z)
        owner = self.map.met_owner(x, y)
        wall = self._wall_angle(owner, x, y, z)
        if wall is not None:
            alpha, nx, ny = wall
            speed = math.hypot(vx, vy)
            side = (vx * ny - vy * nx) / speed if speed > 0.0 else 0.0  # the wall's part left of the travel
            k = 1.0  # a wall angle and its direction change slowly along a part
            if self._last_step > 0.0 and ALPHA_LENGTH_M > 0.0:
                k = 1.0 - math.exp(-self._last_step / ALPHA_LENGTH_M)
            self._alpha += k * (alpha - self._alpha)
            self._side += k * (side - self._side)
        self.map.commit((x, y, z), f_z_n, owner)

    def _wall_angle(self, owner: int, x: float, y: float, z: float) -> tuple[float, float, float] | None:
        """Wall angle at a tool tip from the layers above it [deg], capped, and the horizontal unit direction to
        that layer (zero where its run is under `WALL_RUN_MIN_M`: a step straight down); None where nothing is
        formed.

        Walks from `owner` (of the met cell under (x, y)) to the owner under that commit, and so on, until the
        layer reached lies `WALL_BASELINE_M` above the tip (or the flat sheet): α = atan2(rise, run) over that
        baseline, not over one layer, whose run is comparable to the path's sample spacing.
        """
        if owner < 0:
            return None
        track = self.map.owner_point
        q = track(owner)
        for _ in range(WALL_MAX_LAYERS):
            if q[2] - z >= WALL_BASELINE_M or q[4] < 0:
                break
            q = track(q[4])
        dx, dy = q[0] - x, q[1] - y
        run = math.hypot(dx, dy)
        alpha = min(math.degrees(math.atan2(max(q[2] - z, 0.0), run)), self._amax)
        if run < WALL_RUN_MIN_M:
            return alpha, 0.0, 0.0
        return alpha, dx / run, dy / run

    def _fz_of(self, dh: float, alpha: float, build: float) -> tuple[float, float, float]:
        """(the unsoftened Fz, ∂/∂Δz, f0 = Fz at full build-up) at engagement Δz [m] and wall angle α [deg]."""
        prm = self.params
        g = self._base * alpha * math.cos(math.radians(alpha))
        dmin = prm.step_min_m
        if dh > dmin:  # forming: Aerens's h^0.09, h the scallop height of the engagement
            sin_a = math.sin(math.radians(alpha))
            half = 0.5 * dh / sin_a if sin_a > 0.0 else math.inf
            radius = self.radius
            if half < 0.999 * radius:
                root = math.sqrt(radius * radius - half * half)
                h = radius - root
                dh_ddz = half / root * 0.5 / sin_a
            else:
                h, dh_ddz = radius, 0.0
            f0 = g * (1e3 * h) ** EXPONENT_SCALLOP
            return f0 * build, EXPONENT_SCALLOP * f0 * build / h * dh_ddz, f0
        f0 = g * (1e3 * scallop_height_m(self.radius, dmin, alpha)) ** EXPONENT_SCALLOP
        if dh >= 0.0:  # a shallow engagement: the plastic plateau (h^0.09 is singular at 0)
            return f0 * build, 0.0, f0
        return f0 * build + prm.k_unload_n_per_m * dh, prm.k_unload_n_per_m, f0  # lifted: elastic unloading

    def _fz_linear(self, x: float, y: float, z: float) -> tuple[float, float, float, float]:
        """(the unsoftened Fz, its gradient in x, y, z) at the tool tip [N, N/m]; `_fz` keeps it >= 0."""
        s, sx, sy = self.map.met_height(x, y)
        d0 = self.params.build_up_m
        e = math.exp(-max(-z, 0.0) / d0)
        dbuild_dz = -e / d0 if z < 0.0 else 0.0
        lin, dlin_ddh, f0 = self._fz_of(s - z, self._alpha, 1.0 - e)
        return lin, dlin_ddh * sx, dlin_ddh * sy, -dlin_ddh + f0 * dbuild_dz

    def _fz(self, x: float, y: float, z: float) -> tuple[float, float, float, float]:
        """(Fz, dFz/dx, dFz/dy, dFz/dz) at the tool tip [N, N/m]: `_fz_linear` through a softplus."""
        lin, gx, gy, gz = self._fz_linear(x, y, z)
        w = _SOFTPLUS_N
        if lin > 30.0 * w:
            fz, slope = lin, 1.0
        else:
            ex = math.exp(lin / w)
            fz, slope = w * math.log1p(ex), ex / (1.0 + ex)
        return fz, slope * gx, slope * gy, slope * gz

    def _travel(self, x: float, y: float, jacobian: bool = True) -> tuple[float, float, np.ndarray | None]:
        """Travel direction v including the step from the last committed tip to (x, y), and ∂v/∂(x, y)
        (`twin.process.force.sliding.sliding_direction`); v_prev where the tool has not moved (Jacobian None)."""
        if self._last is None:
            return self._dir[0], self._dir[1], None
        return sliding_direction(
            self._dir, x - self._last[0], y - self._last[1], self.params.direction_length_m, RELEASE_LENGTH_M,
            jacobian,
        )

    def sliding_direction(self, p_sheet_m: np.ndarray) -> tuple[float, float]:
        """The sliding direction (vx, vy) the in-plane force acts against at a tip position [-]; pure."""
        vx, vy, _ = self._travel(float(p_sheet_m[0]), float(p_sheet_m[1]), jacobian=False)
        return vx, vy

    def force_and_stiffness(
        self, p_sheet_m: np.ndarray, pass_index: int = 0, direction: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """Force of the sheet on the tool [N] (3,) and ∂f/∂p [N/m] (3, 3), sheet frame; pure.

        Args:
            p_sheet_m: Tool-tip position (3,) [m].
            pass_index: Ignored (interface of `SheetForceField`).
            direction: Ignored (the travel direction comes from the committed positions).
        """
        x, y, z = float(p_sheet_m[0]), float(p_sheet_m[1]), float(p_sheet_m[2])
        fz, gx, gy, gz = self._fz(x, y, z)
        self._last_fz = ((x, y, z), fz)
        vx, vy, jac = self._travel(x, y)
        (axx, axy), (ayx, ayy) = self._in_plane()
        ax, ay = axx * vx + axy * vy, ayx * vx + ayy * vy
        stiffness = np.array([[ax * gx, ax * gy, ax * gz], [ay * gx, ay * gy, ay * gz], [gx, gy, gz]])
        if jac is not None:
            stiffness[:2, :2] += fz * (np.array([[axx, axy], [ayx, ayy]]) @ jac)
        return np.array([ax * fz, ay * fz, fz]), stiffness

    def _in_plane(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """F_xy = Fz · A · v: A = -(μ_t·I + μ_r·side·L), L the quarter turn to the left of the travel v."""
        mu, mr = self.params.mu_eff, self.params.mu_radial * self._side
        return (-mu, mr), (-mr, -mu)

    def force(self, p_sheet_m: np.ndarray, pass_index: int = 0, direction: int = 1) -> np.ndarray:
        """Force of the sheet on the tool [N], (3,), sheet frame; pure (see `force_and_stiffness`)."""
        x, y, z = float(p_sheet_m[0]), float(p_sheet_m[1]), float(p_sheet_m[2])
        fz = self._fz(x, y, z)[0]
        self._last_fz = ((x, y, z), fz)
        vx, vy, _ = self._travel(x, y, jacobian=False)
        (axx, axy), (ayx, ayy) = self._in_plane()
        return np.array([(axx * vx + axy * vy) * fz, (ayx * vx + ayy * vy) * fz, fz])
