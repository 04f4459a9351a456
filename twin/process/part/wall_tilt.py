"""The wall's tilt when the tool's load is released: the angular springback that leaves a shallow SPIF wall short.

Scanned SPIF cones come out shallower than designed at a 40° wall (0.65-1.1°) and true at 50-70°, and short in
depth by more at the larger step-down (32 cones, `twin/data/spif_cone_scans.csv`); the NUMISHEET 2014 BM3 cone
(45°, AA7075-O, 1.63 mm, `twin/data/bm3_profile_rd.csv`) meets its design at the rim and is about 2.4° shallow
down its wall. Both read as the wall turning about its top edge. The model of that turn:

    Δα = Δα_r Δα_f / (Δα_r + Δα_f)     (the stiffer of two limits, in series)

    Δα_r = C · α · (σ_f / E') · (t_w / ρ) · (Δz / t0)^p · (t0 r_b / (w H X0))^q   restrained by the hoops
    Δα_f = 3 α σ_f ρ / (E' t_w)                                                 a free bend's springback

* the drive, the wall's elastic unloading where the tool leaves it: σ_f / E' the elastic strain of the flow
  stress at the wall's sine-law strain ε = (2/√3) ln(1 / cos α) (plane strain, E' = E / (1 - ν²)); t_w / ρ the
  severity of the bend over the tool (t_w = t0 cos α the sine-law wall thickness, ρ = R + t_w / 2 the tool
  radius at the sheet's mid-plane); α the angle the sheet is bent through; a power p of the step-down (the
  contact a step leaves; fitted);
* the hoops' restraint: a wall that turns about its top moves its lower edge radially by H·Δα and strains the
  hoops there by H·Δα / r_b; against the wall's bending stiffness (∝ t³ / w) the hoops' membrane stiffness
  (∝ t·w) grows as ((w / t0)(H / r_b))², w the wall's plan width, H the depth, r_b the bottom's radius: a deep,
  narrow part turns little, a shallow, wide one more (X0 = 0.025, about the scans' 40° cones; the energy
  argument gives q = 2, the scans a steeper fall: q is fitted). The scans reach no part held less than X0: a
  part beyond is turned as one at X0 (min(., 1)), not by an extrapolated power;
* the bound: a wall free of hoops turns back no more than a free bend through α over ρ does (the elastic
  unloading of a fully plastic bend, Δκ = 3 σ_f / (E' t)).

On a formed surface (`tilt_lift_m`) a node a plan distance d inside the formed region's edge rises by
Δα · (min(d, w) + |z| |∇z|): the wall turned rigidly about its top (d sec²α on a straight wall), the bottom
carried up with the wall's lower edge (w Δα). A part whose surface has no wall, or no bottom (a cone to its
apex), is not turned.

C, p and q are fitted by `twin.apps.springback_scans` on the scans' 40° and 60° conditions, an AA1050-O 1 mm sheet
assumed (the source does not state its sheet), and predicted on the 50° and 70° ones; docs/springback.md has
both, the other splits, the material's spread and the BM3 cone. What the model leaves out: the flange's own
bending near the clamp, the bottom's pillow, the scallop (its height, s² / 8R, is at most 0.03 mm here).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy import ndimage

from twin.errors import InputError

#: C, p, q (module docstring), fitted by `twin.apps.springback_scans.fit_constants` on the scans' 40° and 60°
#: conditions, q held near 2 by a prior (guarded by tests/test_springback_scans.py).
TILT_COEFFICIENT = 425.1
STEP_EXPONENT = 1.127
RESTRAINT_EXPONENT = 3.89
#: X0 of the module docstring: t0 r_b / (w H) of a 40° cone of the scans (1 mm, r_b 20 mm, w 30 mm, H 25 mm).
RESTRAINT_REFERENCE = 0.025
#: A node belongs to the wall where the surface is steeper than this [deg]; to the bottom where flatter and more
#: than half the wall's plan width inside the formed region's edge.
WALL_SLOPE_DEG = 10.0


class TiltConstants(NamedTuple):
    """The model's fitted constants (module docstring).

    Attributes:
        coefficient: C [-].
        step_exponent: p [-].
        restraint_exponent: q [-] (the energy argument of the module docstring gives 2).
    """

    coefficient: float = TILT_COEFFICIENT
    step_exponent: float = STEP_EXPONENT
    restraint_exponent: float = RESTRAINT_EXPONENT


#: The shipped constants.
SHIPPED = TiltConstants()


class Sheet(NamedTuple):
    """What the tilt needs of the sheet and the tool.

    Attributes:
        thickness_m: Initial thickness t0 [m].
        tool_radius_m: Tool radius R [m].
        youngs_modulus_pa: E [Pa].
        poisson_ratio: ν [-].
        hardening_k_pa: K of the flow stress σ_f = K ε^n [Pa].
        hardening_n: n [-].
    """

    thickness_m: float
    tool_radius_m: float
    youngs_modulus_pa: float
    poisson_ratio: float
    hardening_k_pa: float
    hardening_n: float


class WallGeometry(NamedTuple):
    """What the tilt reads off a formed surface (`wall_geometry`).

    Attributes:
        wall_angle_rad: The wall's angle from the sheet plane, the median over its nodes [rad].
        width_m: The wall's plan width w, the farthest wall node from the formed region's edge [m].
        depth_m: The part's depth H [m].
        bottom_radius_m: r_b, the radius of a disc of the bottom's area [m] (0: no bottom).
        lever_m: Per node, min(d, w) + |z| |∇z| [m] (0 outside the formed region), shape (ny, nx).
    """

    wall_angle_rad: float
    width_m: float
    depth_m: float
    bottom_radius_m: float
    lever_m: np.ndarray


def tilt_rad(
    wall_angle_rad: float, step_down_m: float, sheet: Sheet, width_m: float, depth_m: float, bottom_radius_m: float,
    constants: TiltConstants = SHIPPED,
) -> float:
    """The wall's turn Δα about its top [rad] (module docstring); 0 for a part with no bottom.

    Args:
        wall_angle_rad: Wall angle α [rad], in (0, π/2).
        step_down_m: Step-down Δz [m].
        sheet: The sheet and the tool.
        width_m: The wall's plan width w [m].
        depth_m: The part's depth H [m].
        bottom_radius_m: The bottom's radius r_b [m].
        constants: C, p, q.
    """
    values = (wall_angle_rad, step_down_m, width_m, depth_m, bottom_radius_m, *sheet)
    if not all(math.isfinite(v) for v in values) or min(step_down_m, *sheet) <= 0:
        raise InputError(f"tilt_rad: expected finite values and a positive step-down and sheet, got {values!r}")
    if not 0.0 < wall_angle_rad < 0.5 * math.pi or bottom_radius_m <= 0.0 or depth_m <= 0.0:
        return 0.0
    cos_a = math.cos(wall_angle_rad)
    t_wall = sheet.thickness_m * cos_a
    strain = 2.0 / math.sqrt(3.0) * math.log(1.0 / cos_a)
    flow_pa = 2.0 / math.sqrt(3.0) * sheet.hardening_k_pa * strain**sheet.hardening_n
    modulus = sheet.youngs_modulus_pa / (1.0 - sheet.poisson_ratio**2)
    rho = sheet.tool_radius_m + 0.5 * t_wall
    restrained = (constants.coefficient * wall_angle_rad * flow_pa / modulus * t_wall / rho
                  * (step_down_m / sheet.thickness_m) ** constants.step_exponent
                  * min(sheet.thickness_m * bottom_radius_m / (width_m * depth_m * RESTRAINT_REFERENCE), 1.0)
                  ** constants.restraint_exponent)
    free = 3.0 * wall_angle_rad * flow_pa * rho / (modulus * t_wall)
    return restrained * free / (restrained + free) if restrained > 0 else 0.0


def wall_geometry(x_m: np.ndarray, y_m: np.ndarray, z_m: np.ndarray, formed_below_m: float) -> WallGeometry | None:
    """The wall, the bottom and each node's lever on a formed surface; None when it has no wall.

    Args:
        x_m, y_m: The grid [m], shapes (nx,), (ny,), evenly spaced.
        z_m: Heights [m] (<= 0 where formed), shape (ny, nx).
        formed_below_m: A node is formed where it lies this far below the flat sheet [m].
    """
    h = float(x_m[1] - x_m[0])
    formed = z_m < -formed_below_m
    gy, gx = np.gradient(z_m, h, h)
    slope = np.hypot(gx, gy)
    wall = formed & (slope > math.tan(math.radians(WALL_SLOPE_DEG)))
    if not wall.any():
        return None
    inside = ndimage.distance_transform_edt(formed) * h
    width = float(inside[wall].max())
    bottom = formed & ~wall & (inside > 0.5 * width)
    lever = np.where(formed, np.minimum(inside, width) + np.abs(z_m) * slope, 0.0)
    return WallGeometry(float(np.median(np.arctan(slope[wall]))), width, float(-z_m.min()),
                        math.sqrt(bottom.sum() * h * h / math.pi), lever)


def step_down_from_track(track_m: np.ndarray) -> float | None:
    """The step-down of a tool-tip track [m]: its depth over the turns it made about its centre; None for a track
    that makes no full turn.

    Args:
        track_m: Tool-tip positions in order [m], shape (k, >= 3).
    """
    if len(track_m) < 3:
        return None
    rel = track_m[:, :2] - track_m[:, :2].mean(axis=0)
    turned = np.abs(np.diff(np.unwrap(np.arctan2(rel[:, 1], rel[:, 0])))).sum() / (2.0 * math.pi)
    depth = float(track_m[:, 2].max() - track_m[:, 2].min())
    return depth / turned if turned >= 1.0 and depth > 0.0 else None


def tilt_lift_m(
    x_m: np.ndarray, y_m: np.ndarray, z_m: np.ndarray, track_m: np.ndarray, sheet: Sheet, formed_below_m: float,
    constants: TiltConstants = SHIPPED,
) -> np.ndarray:
    """How far each node of a formed surface rises when its wall turns about its top [m] (module docstring).

    Args:
        x_m, y_m: The grid [m], shapes (nx,), (ny,).
        z_m: The formed surface [m], shape (ny, nx).
        track_m: The tool-tip track that formed it [m] (its step-down).
        sheet: The sheet and the tool.
        formed_below_m: A node is formed where it lies this far below the flat sheet [m].
        constants: C, p, q.

    Returns:
        The lift [m] (>= 0), shape (ny, nx); zeros for a surface with no wall, no bottom or no full turn.
    """
    geometry = wall_geometry(x_m, y_m, z_m, formed_below_m)
    step = step_down_from_track(track_m)
    if geometry is None or step is None:
        return np.zeros_like(z_m)
    turn = tilt_rad(geometry.wall_angle_rad, step, sheet, geometry.width_m, geometry.depth_m,
                    geometry.bottom_radius_m, constants)
    return turn * geometry.lever_m
