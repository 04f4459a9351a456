"""A general ISF force model on the formed-surface height map: the force on the tool for any part and path.

State: `twin.process.heightmap.HeightMap` (2-D, 0.5 mm grid, lower envelope of the tool sphere, elastic
recovery), driven by `advance`. At a tool-tip position p = (x, y, z) in the sheet frame, from the *met* surface
S (the surface formed before the tool got here):

* step-down (engagement) Δh = S(x, y) - z, the depth of the tool tip below the surface it meets [mm];
* local wall angle α, from the layers above the tool: the met cell under the tip was formed by an earlier tool
  position (its owner), the cell under that one by another, and so on; walking up until the layer reached lies
  1 mm above the tip, α = atan2(rise, horizontal run) to it (a cone's previous revolutions, for instance), capped
  at α_max: a step straight down, as in the zig-zag groove, is no cone wall, and α_max is calibrated on the
  groove's FE history (63.6°, close to the groove's 63.4° end walls); the model holds α and moves it towards each
  reading over 10 mm of travel (a wall angle changes slowly along a part; single readings jump with the path's
  sampling and with the tool's deflection, and made twin compensation stall), starting at α_max (first
  contact) and keeping it over sheet never formed;
* forming (Δh > Δh_min): the steady-state vertical force of Aerens et al., "Force prediction for single point
  incremental forming deduced from experimental and FEM observations", CIRP Annals 59 (2010) 269-272,

      Fz = 0.0716 · R_m · t^1.57 · d_t^0.41 · Δh^0.09 · α · cos α · B(D)      [N; MPa, mm, deg]

  with the tool diameter d_t = 2R, and the build-up B(D) = 1 - exp(-D/D0) over the depth D = -z below the
  original sheet (SPIF forces rise over the first millimetres of depth to a plateau; D0 calibrated, ~2 mm);
* a shallow engagement 0 <= Δh <= Δh_min: the plateau Fz(Δh_min) (Δh^0.09 is singular at 0: its stiffness
  0.09·Fz/Δh would grow without bound; Δh_min caps it near k_unload);
* elastic (Δh < 0, the tool has risen from the surface it meets): Fz(Δh_min) + k_unload·Δh, continuous,
  falling to zero by the sheet's elastic recovery; a softplus (5 N) keeps Fz >= 0 and smooth;
* in-plane force against the sliding: F_xy = -μ_eff·Fz·v, v the sliding direction implicit in the queried
  position (`twin.process.sliding`): it turns over L_f of travel (|v| = 1 on a straight run); a tool that
  reverses leaves the wall it was pushing, so v is released over 0.05 mm and the in-plane force builds up
  against the new travel as 1 - exp(-u/L_f). A tool pushed sideways meets friction against that motion (an
  explicit, one-sample-late direction made the twin's lateral deflection oscillate sample to sample). μ_eff
  lumps the friction 0.1 (§2.4.2) and the ploughing of the wall ahead.

Material and tool (§1.2.2, §2.2): AA5086-H111, t = 1 mm, R = 7.5 mm, friction 0.1. Aerens's formula wants the
tensile strength R_m: 275 MPa, the handbook value the stand-in history uses; the thesis's Voce law
σ = 130.2 + 300.37·sqrt(1 - exp(-3.94 ε)) MPa necks (dσ/dε = σ) at ε ≈ 0.205, σ ≈ 354 MPa, i.e. an engineering
R_m ≈ 354·e^-0.205 ≈ 288 MPa: within 5 %. Validity: the formula is a regression on SPIF experiments (cones and
pyramids); we use it for wall angles 30-70°, step-downs 0.1-1 mm, t = 1 mm, Ø 15 mm and have not checked those
against the paper's exact ranges. It gives no force on a flat sheet (α = 0) and peaks at α = 49.3° (α·tan α = 1
in radians): steeper walls get *less* force from it. The stiffness ∂f/∂p is analytic (Δh^0.09, the build-up, the
slope of the met surface, the implicit sliding direction); α is state and not differentiated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twin.errors import InputError
from twin.process.field import K_UNLOAD_N_PER_M, SOFTPLUS_N, TOOL_RADIUS_M
from twin.process.force_field import FieldState, ForceField
from twin.process.heightmap import HeightMap
from twin.process.sliding import RELEASE_LENGTH_M, sliding_direction

#: Aerens et al. (2010) coefficient of the steady-state Fz formula [N / (MPa mm^2.07 deg)].
AERENS_COEFFICIENT = 0.0716
_SOFTPLUS_N = SOFTPLUS_N
#: Height over which the wall angle is read from the layers above the tool [m], and the most layers walked.
WALL_BASELINE_M = 1.0e-3
WALL_MAX_LAYERS = 12
#: Travel over which the held wall angle follows its readings [m] (0: jump to each reading).
ALPHA_LENGTH_M = 10e-3


@dataclass(frozen=True)
class IsfForceParams:
    """Constants of the ISF force model (defaults: thesis material and tool; calibrated values, see
    `twin.process.isf_calibration` and docs/any-part.md).

    Attributes:
        tensile_strength_mpa: R_m of the sheet [MPa].
        thickness_m: Sheet thickness t [m].
        tool_radius_m: Tool radius R [m].
        wall_angle_max_deg: Cap α_max of the local wall angle [deg] (calibrated on the groove).
        build_up_m: Build-up depth D0 [m] (calibrated).
        mu_eff: In-plane over vertical force, against the travel [-] (calibrated).
        direction_length_m: Length L_f over which the sliding direction turns and builds up [m] (calibrated).
        step_min_m: Engagement Δh_min below which the force stays at its Δh_min value [m] (calibrated).
        k_unload_n_per_m: Elastic unloading stiffness of the formed sheet [N/m] (`twin.process.field`).
        scale: Factor on Fz and F_xy [-] (1: Aerens as published; a real cell's forces may differ).
        spacing_m: Height-map grid spacing [m].
    """

    tensile_strength_mpa: float = 275.0
    thickness_m: float = 1.0e-3
    tool_radius_m: float = TOOL_RADIUS_M
    wall_angle_max_deg: float = 63.63
    build_up_m: float = 1.966e-3
    mu_eff: float = 0.3052
    direction_length_m: float = 0.996e-3
    step_min_m: float = 0.2e-3
    k_unload_n_per_m: float = K_UNLOAD_N_PER_M
    scale: float = 1.0
    spacing_m: float = 0.5e-3

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InputError(f"IsfForceParams.{name} = {value!r}: expected a finite number > 0")
        if not 0.0 < self.wall_angle_max_deg < 90.0:
            raise InputError(f"IsfForceParams.wall_angle_max_deg = {self.wall_angle_max_deg!r}: expected (0, 90)")


def aerens_fz_n(params: IsfForceParams, step_down_m: float, wall_angle_deg: float) -> float:
    """Aerens's steady-state Fz for the params' material and tool [N] (no build-up, no scale)."""
    return (
        AERENS_COEFFICIENT
        * params.tensile_strength_mpa
        * (params.thickness_m * 1e3) ** 1.57
        * (2e3 * params.tool_radius_m) ** 0.41
        * (step_down_m * 1e3) ** 0.09
        * wall_angle_deg
        * math.cos(math.radians(wall_angle_deg))
    )


@dataclass(frozen=True)
class IsfMotion(FieldState):
    """The ISF model's scalar state besides its height map.

    Attributes:
        direction: Held sliding direction (vx, vy) [-].
        last_tip_m: Last committed tool tip (x, y, z) [m], or None before the first.
        wall_angle_deg: Held wall angle [deg].
        last_step_m: Length of the last committed step [m].
    """

    direction: tuple[float, float]
    last_tip_m: tuple[float, float, float] | None
    wall_angle_deg: float
    last_step_m: float


class IsfForceField(ForceField):
    """Force of the sheet on the tool at any tool position, on the height map (a `ForceField`, compiled kernel
    `isf`).

    `pass_index` and `direction` are accepted for the interface and ignored: the model needs no pass labels, and
    its in-plane force follows the tool's own travel.

    Args:
        params: Model constants; None for the calibrated defaults.
        half_size_m: Half-extent (x, y) of the modelled sheet [m].
    """

    compiled_kernel = "isf"

    def __init__(self, params: IsfForceParams | None = None, half_size_m: tuple[float, float] = (0.12, 0.12)) -> None:
        self.params = p = params or IsfForceParams()
        self.map = HeightMap(p.tool_radius_m, p.spacing_m, half_size_m)
        self.radius = p.tool_radius_m
        self.k_unload = p.k_unload_n_per_m
        self.k_load = 0.09 * aerens_fz_n(p, 1e-3, p.wall_angle_max_deg) / 1e-3  # dFz/dΔh at 1 mm, for reports
        self._amax = p.wall_angle_max_deg
        self._base = p.scale * aerens_fz_n(p, 1e-3, 1.0) / math.cos(math.radians(1.0))  # Fz / (Δh_mm^.09 α cosα)
        self._dir = (0.0, 0.0)
        self._last: tuple[float, float, float] | None = None
        self._alpha = self._amax
        self._last_fz = ((math.nan, math.nan, math.nan), 0.0)
        self.reset()

    def reset(self) -> None:
        """Back to a flat, unformed sheet."""
        self.map.reset()
        self._dir = (0.0, 0.0)
        self._last = None
        self._alpha = self._amax
        self._last_step = 0.0
        self._last_fz = ((math.nan, math.nan, math.nan), 0.0)

    @property
    def base_fz_n(self) -> float:
        """Fz / (Δh_mm^0.09 · α · cos α) of the params' material, tool and scale [N]."""
        return self._base

    @property
    def state(self) -> IsfMotion:
        """Sliding direction, last committed tip, held wall angle and last step."""
        return IsfMotion(self._dir, self._last, self._alpha, self._last_step)

    def restore(self, state: FieldState) -> None:
        """Set the motion state (a loop that advanced the map itself, the compiled replay)."""
        if not isinstance(state, IsfMotion):
            raise InputError(f"state {state!r} is not an IsfMotion")
        self._dir, self._last, self._alpha, self._last_step = (
            state.direction, state.last_tip_m, state.wall_angle_deg, state.last_step_m
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
        alpha = self._wall_angle(owner, x, y, z)
        if alpha is not None:
            if self._last_step > 0.0 and ALPHA_LENGTH_M > 0.0:  # a wall angle changes slowly along a part
                k = 1.0 - math.exp(-self._last_step / ALPHA_LENGTH_M)
                self._alpha += k * (alpha - self._alpha)
            else:
                self._alpha = alpha
        self.map.commit((x, y, z), f_z_n, owner)

    def _wall_angle(self, owner: int, x: float, y: float, z: float) -> float | None:
        """Wall angle at a tool tip from the layers above it [deg], capped; None where nothing is formed.

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
        return min(math.degrees(math.atan2(max(q[2] - z, 0.0), math.hypot(q[0] - x, q[1] - y))), self._amax)

    def _fz(self, x: float, y: float, z: float) -> tuple[float, float, float, float]:
        """(Fz, dFz/dx, dFz/dy, dFz/dz) at the tool tip [N, N/m]."""
        prm = self.params
        s, sx, sy = self.map.met_height(x, y)
        dh = s - z
        alpha = self._alpha
        depth = max(-z, 0.0)
        e = math.exp(-depth / prm.build_up_m)
        build = 1.0 - e
        dbuild_dz = -e / prm.build_up_m if z < 0.0 else 0.0
        g = self._base * alpha * math.cos(math.radians(alpha))
        dmin = prm.step_min_m
        if dh > dmin:  # forming: Aerens's Δh^0.09
            f0 = g * (dh * 1e3) ** 0.09
            lin, dlin_ddh = f0 * build, 0.09 * f0 * build / dh
        elif dh >= 0.0:  # a shallow engagement: the plastic plateau (Δh^0.09 is singular at 0)
            f0 = g * (dmin * 1e3) ** 0.09
            lin, dlin_ddh = f0 * build, 0.0
        else:  # lifted above the surface it meets: elastic unloading
            f0 = g * (dmin * 1e3) ** 0.09
            lin, dlin_ddh = f0 * build + prm.k_unload_n_per_m * dh, prm.k_unload_n_per_m
        dlin_dz = -dlin_ddh + f0 * dbuild_dz
        w = _SOFTPLUS_N
        if lin > 30.0 * w:
            fz, slope = lin, 1.0
        else:
            ex = math.exp(lin / w)
            fz, slope = w * math.log1p(ex), ex / (1.0 + ex)
        return fz, slope * dlin_ddh * sx, slope * dlin_ddh * sy, slope * dlin_dz

    def _travel(self, x: float, y: float, jacobian: bool = True) -> tuple[float, float, np.ndarray | None]:
        """Travel direction v including the step from the last committed tip to (x, y), and ∂v/∂(x, y)
        (`twin.process.sliding.sliding_direction`); v_prev where the tool has not moved (Jacobian None)."""
        if self._last is None:
            return self._dir[0], self._dir[1], None
        return sliding_direction(
            self._dir, x - self._last[0], y - self._last[1], self.params.direction_length_m, RELEASE_LENGTH_M,
            jacobian,
        )

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
        mu = -self.params.mu_eff
        stiffness = np.array(
            [[mu * vx * gx, mu * vx * gy, mu * vx * gz], [mu * vy * gx, mu * vy * gy, mu * vy * gz], [gx, gy, gz]]
        )
        if jac is not None:
            stiffness[:2, :2] += (mu * fz) * jac
        return np.array([mu * vx * fz, mu * vy * fz, fz]), stiffness

    def force(self, p_sheet_m: np.ndarray, pass_index: int = 0, direction: int = 1) -> np.ndarray:
        """Force of the sheet on the tool [N], (3,), sheet frame; pure (see `force_and_stiffness`)."""
        x, y, z = float(p_sheet_m[0]), float(p_sheet_m[1]), float(p_sheet_m[2])
        fz = self._fz(x, y, z)[0]
        self._last_fz = ((x, y, z), fz)
        vx, vy, _ = self._travel(x, y, jacobian=False)
        mu = self.params.mu_eff
        return np.array([-mu * vx * fz, -mu * vy * fz, fz])
