"""The formed part held to 32 scanned SPIF cones: the wall's tilt (`twin.process.part.wall_tilt`) fitted on two wall
angles and predicted on the other two, against the scans' per-condition means (`twin/data/spif_cone_scans.csv`).

Each condition's cone is formed on the rigid machine (`twin.process.part.springback.form_rigidly`, the `isf`
force model with the condition's tool and step-down, z-level), unclamped (`twin.process.part.surface`), and
measured as the source measured its scans (MGralha/codigos-finais, `bibliotecas/divisaodedados.py`: the
flange's mean height over radius 52-75 mm, a line fitted over radius 22-48 mm for the wall's angle, the bottom's
mean over 0-18 mm). The designs put the wall between radius 50 and 20 mm at every angle (their depths are
30.0 mm x tan α; the source's windows fit it): the tool-tip contour starts at 50 mm - R tan(α/2), where the
sphere's envelope meets the flat sheet at 50 mm.

The source states neither the sheet nor the machine: an AA1050-O 1 mm sheet is assumed (a common SPIF alloy
at that school; `SPREAD` says how far the fit moves over other plausible sheets). The fit weighs an angle by
0.2° and a depth by 0.1 mm, about the spread between the two parts of a condition.
"""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from scipy import optimize

from twin.base.resources import data_file
from twin.errors import ExtrapolationWarning, InputError
from twin.process.description import Process
from twin.process.force.isf import IsfForceField
from twin.process.force.isf_params import params_for
from twin.process.material.file import material
from twin.process.part.springback import form_rigidly
from twin.process.part.surface import FORMED_BELOW_M, formed_surface, sheet_of
from twin.process.part.wall_tilt import Sheet, TiltConstants, step_down_from_track, tilt_rad, wall_geometry
from twin.process.toolpath.groove import ToolPath
from twin.process.toolpath.shapes import PartSpec, part_path

#: The designs' wall: from radius 50 mm at the sheet down to 20 mm [m] (module docstring).
TOP_RADIUS_M = 0.050
#: The source's windows [mm]: flange, wall, bottom (radius from the cone's axis).
FLANGE_MM, WALL_MM, BOTTOM_MM = (52.0, 75.0), (22.0, 48.0), (0.0, 18.0)
#: The wall angles the shipped constants are fitted on; the others are predicted.
FITTED_ANGLES = (40.0, 60.0)
#: The assumed sheet, and the others the spread is shown over.
ASSUMED = "AA1050-O"
SPREAD = ("AA1050-O", "AA3003-O", "AA5754-O")
#: Weights of the fit: an angle in 0.2°, a depth in 0.1 mm.
ANGLE_SCALE_DEG, DEPTH_SCALE_MM = 0.2, 0.1
#: The restraint's exponent q is held near the energy argument's 2 by a prior of this mean and spread: the two
#: fitted angles say only that the tilt falls fast between them (q from 5 to 10 fits them alike).
RESTRAINT_PRIOR = (2.0, 2.0)


class ScanCondition(NamedTuple):
    """One of the 16 conditions, designed and measured (`twin/data/spif_cone_scans.csv`).

    Attributes:
        wall_angle_deg, step_down_mm, tool_diameter_mm, design_depth_mm: The design.
        angle_deg, height_mm: The scans' means over both parts.
    """

    wall_angle_deg: float
    step_down_mm: float
    tool_diameter_mm: float
    design_depth_mm: float
    angle_deg: float
    height_mm: float


class FormedCone(NamedTuple):
    """A condition's cone formed with no tilt, ready for any tilt (the measurement is cheap)."""

    condition: ScanCondition
    z_m: np.ndarray
    lever_m: np.ndarray
    radius_mm: np.ndarray
    inputs: tuple[float, float, float, float, float]
    sheet: Sheet


class Measured(NamedTuple):
    """Short of the design, as the scans measure it: the wall's angle [deg] and the depth [mm]."""

    angle_short_deg: float
    depth_short_mm: float


def read_scans() -> tuple[ScanCondition, ...]:
    """The 16 conditions of `twin/data/spif_cone_scans.csv`."""
    lines = [line for line in data_file("spif_cone_scans.csv").read_text(encoding="utf-8").splitlines()
             if line and not line.startswith("#")]
    head = lines[0].split(",")
    rows = [dict(zip(head, line.split(","), strict=True)) for line in lines[1:]]
    return tuple(ScanCondition(*(float(r[k]) for k in ("wall_angle_deg", "step_down_mm", "tool_diameter_mm",
                                                        "design_depth_mm", "angle_deg", "height_mm")))
                 for r in rows)


class Unclamped(NamedTuple):
    """A part formed rigidly and unclamped with no tilt, and what its tilt needs (`unclamped`).

    Attributes:
        x_m, y_m, z_m: Its surface [m].
        lever_m: Each node's lever on the tilt [m] (`twin.process.part.wall_tilt.WallGeometry`).
        inputs: Wall angle [rad], step-down [m], plan width [m], depth [m], bottom radius [m].
        sheet: The sheet and tool.
    """

    x_m: np.ndarray
    y_m: np.ndarray
    z_m: np.ndarray
    lever_m: np.ndarray
    inputs: tuple[float, float, float, float, float]
    sheet: Sheet


def unclamped(process: Process, path: ToolPath) -> Unclamped:
    """Form `path` rigidly with the `isf` model of `process`, unclamp it without the tilt (`Unclamped`)."""
    field = IsfForceField(params_for(replace(process, force_model="isf"), wall_tilt_scale=0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        form_rigidly(path, field)
    surface = formed_surface(field)
    assert surface is not None  # the isf field keeps a height map
    x, y, z = surface
    geometry = wall_geometry(x, y, z, FORMED_BELOW_M)
    step = step_down_from_track(field.map.track_m)
    if geometry is None or step is None:
        raise InputError("unclamped: the part has no wall, or its track no full turn")
    inputs = (geometry.wall_angle_rad, step, geometry.width_m, geometry.depth_m, geometry.bottom_radius_m)
    return Unclamped(x, y, z, geometry.lever_m, inputs, sheet_of(replace(field.params, wall_tilt_scale=1.0)))


def form(condition: ScanCondition, sheet_material: str = ASSUMED, thickness_m: float = 1e-3) -> FormedCone:
    """Form a condition's cone rigidly and unclamp it without the tilt (`FormedCone`)."""
    radius = 0.5e-3 * condition.tool_diameter_mm
    alpha = math.radians(condition.wall_angle_deg)
    process = Process(material=sheet_material, tensile_strength_mpa=material(sheet_material).tensile_strength_mpa,
                      thickness_m=thickness_m, tool_radius_m=radius)
    path = part_path(PartSpec(shape="cone", top_half_width_m=TOP_RADIUS_M - radius * math.tan(0.5 * alpha),
                              depth_m=1e-3 * condition.design_depth_mm, wall_angle_deg=condition.wall_angle_deg,
                              step_down_m=1e-3 * condition.step_down_mm, mode="z-level"))
    part = unclamped(process, path)
    radius_mm = 1e3 * np.hypot(*np.meshgrid(part.x_m, part.y_m))
    return FormedCone(condition, part.z_m, part.lever_m, radius_mm, part.inputs, part.sheet)


def measure(cone: FormedCone, turn_rad: float) -> Measured:
    """The cone turned by `turn_rad`, measured as the source measured its scans (module docstring)."""
    z_mm = 1e3 * np.minimum(cone.z_m + turn_rad * cone.lever_m, 0.0)
    r = cone.radius_mm

    def band(window: tuple[float, float]) -> np.ndarray:
        return (r > window[0]) & (r <= window[1])

    height = float(z_mm[band(FLANGE_MM)].mean() - z_mm[band(BOTTOM_MM)].mean())
    slope = np.polyfit(r[band(WALL_MM)], z_mm[band(WALL_MM)], 1)[0]
    c = cone.condition
    return Measured(c.wall_angle_deg - math.degrees(math.atan(abs(slope))), c.design_depth_mm - height)


def turn(cone: FormedCone, constants: TiltConstants) -> float:
    """The model's tilt of a formed cone with given constants [rad]."""
    angle, step, width, depth, bottom = cone.inputs
    return tilt_rad(angle, step, cone.sheet, width, depth, bottom, constants)


def predictions(cones: list[FormedCone], constants: TiltConstants | None) -> np.ndarray:
    """(angle short [deg], depth short [mm]) per cone; `constants` None: no tilt. Shape (n, 2)."""
    return np.array([measure(c, 0.0 if constants is None else turn(c, constants)) for c in cones])


def measured(cones: list[FormedCone]) -> np.ndarray:
    """The scans' (angle short [deg], depth short [mm]) per cone, shape (n, 2)."""
    return np.array([(c.condition.wall_angle_deg - c.condition.angle_deg,
                      c.condition.design_depth_mm - c.condition.height_mm) for c in cones])


def fit_constants(cones: list[FormedCone], angles: tuple[float, ...] = FITTED_ANGLES) -> TiltConstants:
    """C, p and q by least squares on the cones of the given wall angles (module docstring's weights)."""
    keep = [c for c in cones if c.condition.wall_angle_deg in angles]
    target = measured(keep)
    scale = np.array([ANGLE_SCALE_DEG, DEPTH_SCALE_MM])

    def residual(q: np.ndarray) -> np.ndarray:
        got = predictions(keep, TiltConstants(math.exp(q[0]), float(q[1]), float(q[2])))
        return np.append(((got - target) / scale).ravel(), (q[2] - RESTRAINT_PRIOR[0]) / RESTRAINT_PRIOR[1])

    best = min((optimize.least_squares(residual, start, diff_step=1e-3)
                for start in ([3.0, 0.8, 2.0], [5.0, 1.0, 4.0], [6.0, 1.0, 8.0])), key=lambda r: r.cost)
    return TiltConstants(math.exp(best.x[0]), float(best.x[1]), float(best.x[2]))


def rms(error: np.ndarray) -> tuple[float, float]:
    """RMS of (angle, depth) errors over rows."""
    return float(np.sqrt(np.mean(error[:, 0] ** 2))), float(np.sqrt(np.mean(error[:, 1] ** 2)))


Split = tuple[tuple[float, ...], tuple[float, float], tuple[float, float]]


def splits(cones: list[FormedCone]) -> list[Split]:
    """Every choice of two wall angles fitted: (fitted angles, predicted rms with the tilt, without)."""
    target = measured(cones)
    before = predictions(cones, None)
    out: list[Split] = []
    for pair in itertools.combinations(sorted({c.condition.wall_angle_deg for c in cones}), 2):
        rest = np.array([c.condition.wall_angle_deg not in pair for c in cones])
        after = predictions(cones, fit_constants(cones, pair))
        out.append((pair, rms((after - target)[rest]), rms((before - target)[rest])))
    return out
