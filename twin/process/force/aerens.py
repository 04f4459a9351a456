"""The published steady-state axial force of single point incremental forming, as Aerens et al. state it.

Aerens, Eyckens, Van Bael, Duflou, "Force prediction for single point incremental forming deduced from
experimental and FEM observations", Int J Adv Manuf Technol 46 (2010) 969-982, doi:10.1007/s00170-009-2160-2,
their general formula (Eq. 30):

    Fz_s = 0.0716 · R_m · t^1.57 · d_t^0.41 · Δh^0.09 · α · cos α        [N; MPa, mm, mm, mm, deg]

with R_m the tensile strength, t the initial sheet thickness, d_t the tool diameter, α the wall angle from the
sheet plane **in degrees in both places**, and Δh the **scallop height**: the height of the ridge a ball tool of
radius R leaves between two contours a step-down Δz apart on a wall of angle α. The contours lie s = Δz / sin α
apart along the wall, and the ridge between two spheres of radius R rises h = R - sqrt(R² - (s/2)²) ≈ s²/(8R)
above their bottoms (`scallop_height_m`). A few micrometres to a few hundredths of a millimetre at usual
settings: Δh^0.09 is the formula's way of saying that the step-down matters little. Read with the step-down in
place of the scallop height, the formula gives 29-67 % more force on usual cones (AA5086, 1 mm, Ø 15 mm, 45°,
0.5 mm: 1775 N instead of 1236 N); the paper's own DC01 regression (Eq. 13) agrees with Eq. 30 to 0.3 % only
when both are read with the scallop height (a check of two public secondary sources, not of the paper).

The paper's regression was fitted to SPIF cones and pyramids; its own table of experimental conditions was not
read here. `VALIDITY` is the range the twin declares (our choice, from the conditions of the published
measurements in docs/force-validation.md and usual SPIF practice: sheets of 0.5-2 mm, tools of Ø 5-25 mm,
step-downs of 0.1-1 mm, walls of 20-70°); outside it `validity_warnings` names what is extrapolated. The force
model warns, it does not refuse. The formula's α·cos α peaks at α = 49.3°
(α·tan α = 1 with α in radians): steeper walls get less force from it, as Aerens's measurements of thinning
walls show.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from twin.errors import InputError

#: Aerens et al. (2010) Eq. 30: coefficient and exponents of R_m, t, d_t and Δh [N / (MPa mm^2.07 deg)].
AERENS_COEFFICIENT = 0.0716
EXPONENT_THICKNESS = 1.57
EXPONENT_TOOL = 0.41
EXPONENT_SCALLOP = 0.09


class ValidRange(NamedTuple):
    """Range of one condition over which the formula was fitted.

    Attributes:
        name: The condition, as a user would name it.
        low: Lowest value of the experiments.
        high: Highest value of the experiments.
        unit: Its unit.
    """

    name: str
    low: float
    high: float
    unit: str


#: The declared range of the formula (module docstring: our choice, not the paper's table), `validity_warnings`.
VALIDITY = (
    ValidRange("sheet thickness", 0.5, 2.0, "mm"),
    ValidRange("tool diameter", 5.0, 25.0, "mm"),
    ValidRange("step-down", 0.1, 1.0, "mm"),
    ValidRange("wall angle", 20.0, 70.0, "deg"),
)


def scallop_height_m(tool_radius_m: float, step_down_m: float, wall_angle_deg: float) -> float:
    """Height of the ridge between two contours a step-down apart on a wall [m] (module docstring).

    Args:
        tool_radius_m: Tool radius R [m].
        step_down_m: Vertical distance Δz between the contours [m].
        wall_angle_deg: Wall angle α from the sheet plane [deg]; at 0 (flat) the ridge is the whole sphere, R.
    """
    sin_a = math.sin(math.radians(wall_angle_deg))
    if sin_a <= 0.0:
        return tool_radius_m
    half_pitch = 0.5 * step_down_m / sin_a
    if half_pitch >= tool_radius_m:
        return tool_radius_m
    return tool_radius_m - math.sqrt(tool_radius_m**2 - half_pitch**2)


def aerens_fz_n(
    tensile_strength_mpa: float, thickness_m: float, tool_radius_m: float, step_down_m: float, wall_angle_deg: float
) -> float:
    """Aerens et al.'s steady-state axial force, Eq. 30 with the scallop height [N].

    Args:
        tensile_strength_mpa: R_m of the sheet [MPa].
        thickness_m: Initial sheet thickness t [m].
        tool_radius_m: Tool radius R [m] (the formula takes the diameter 2R).
        step_down_m: Step-down Δz [m].
        wall_angle_deg: Wall angle α [deg].
    """
    if not (tensile_strength_mpa > 0 and thickness_m > 0 and tool_radius_m > 0 and step_down_m > 0):
        raise InputError(
            f"aerens_fz_n: R_m {tensile_strength_mpa!r} MPa, t {thickness_m!r} m, R {tool_radius_m!r} m and "
            f"step-down {step_down_m!r} m must all be > 0"
        )
    scallop_mm = 1e3 * scallop_height_m(tool_radius_m, step_down_m, wall_angle_deg)
    return (
        AERENS_COEFFICIENT
        * tensile_strength_mpa
        * (1e3 * thickness_m) ** EXPONENT_THICKNESS
        * (2e3 * tool_radius_m) ** EXPONENT_TOOL
        * scallop_mm**EXPONENT_SCALLOP
        * wall_angle_deg
        * math.cos(math.radians(wall_angle_deg))
    )


def validity_warnings(
    thickness_m: float, tool_radius_m: float, step_down_m: float | None = None, wall_angle_deg: float | None = None
) -> list[str]:
    """What lies outside the formula's experiments (`VALIDITY`), one sentence each; empty inside.

    Args:
        thickness_m: Sheet thickness [m].
        tool_radius_m: Tool radius [m].
        step_down_m: Step-down [m], or None (not checked).
        wall_angle_deg: Wall angle [deg], or None (not checked).
    """
    values = {
        "sheet thickness": 1e3 * thickness_m,
        "tool diameter": 2e3 * tool_radius_m,
        "step-down": None if step_down_m is None else 1e3 * step_down_m,
        "wall angle": wall_angle_deg,
    }
    out = []
    for rng in VALIDITY:
        value = values[rng.name]
        if value is not None and not rng.low <= value <= rng.high:
            out.append(
                f"{rng.name} {value:g} {rng.unit} lies outside {rng.low:g}-{rng.high:g} {rng.unit}, the declared range "
                "of Aerens et al.'s force formula (twin.process.force.aerens): the axial force is extrapolated"
            )
    return out
