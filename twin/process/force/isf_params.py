"""The constants of the height-map ISF force model (`twin.process.force.isf`) and where each comes from.

* From the process: R_m, t and R (`params_for`): the force level is the user's material, sheet and tool through
  Aerens et al.'s formula (`twin.process.force.aerens`), never refitted to an FE history.
* From the geometry of the groove: the wall-angle cap α_max = 63.43°, the groove's end walls (atan 2).
* From published measurements: the build-up depth D0 (`BUILD_UP_SOURCE`) and the in-plane ratios μ_t, μ_r
  (`MU_SOURCE`).
* Fitted to the groove's stand-in FE history (our own data, `twin.process.force.isf_calibration`): the direction
  length L_f and the plateau engagement Δz_min, which shape the groove's reversals and shallow passes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from twin.errors import InputError
from twin.process.description import Process
from twin.process.force.aerens import AERENS_COEFFICIENT, EXPONENT_THICKNESS, EXPONENT_TOOL, aerens_fz_n
from twin.process.force.table import K_UNLOAD_N_PER_M, TOOL_RADIUS_M
from twin.process.material.file import material
from twin.process.material.hardening import power_law_equivalent

#: Where the build-up depth comes from (fitted by `twin.apps.force_validation.fit_build_up`, guarded by a test).
BUILD_UP_SOURCE = (
    "Neto, Martins, Oliveira, Menezes, Alves, Int J Adv Manuf Technol 85 (2016) 521-534, Fig. 8: the measured "
    "axial force of the NUMISHEET 2014 benchmark 3 cone (AA7075-O, 1.63 mm, Ø 12.66 mm, 45°, 0.5 mm) over depth"
)
#: Where the in-plane ratios come from: the only published radial/tangential split found, an FE result.
MU_SOURCE = (
    "Neto et al. (2016) Fig. 8, DD3IMP FE of the same cone, steady wall: Fz 1819 N, radial 413 N, tangential "
    "187 N (an FE split; no measured split was found)"
)


@dataclass(frozen=True)
class IsfForceParams:
    """Constants of the ISF force model (defaults: thesis material and tool; calibrated values, see
    `twin.process.force.isf_calibration` and docs/any-part.md).

    Attributes:
        tensile_strength_mpa: R_m of the sheet [MPa].
        thickness_m: Sheet thickness t [m].
        tool_radius_m: Tool radius R [m].
        wall_angle_max_deg: Cap α_max of the local wall angle [deg] (the groove's end walls, geometry).
        build_up_m: Build-up depth D0 [m] (fitted to published depth curves, `BUILD_UP_SOURCE`).
        mu_eff: Tangential in-plane over axial force μ_t, against the travel [-] (`MU_SOURCE`).
        mu_radial: Radial in-plane over axial force μ_r, away from the wall [-] (`MU_SOURCE`).
        direction_length_m: Length L_f over which the sliding direction turns and builds up [m] (fitted to the
            groove's stand-in history: our own data).
        step_min_m: Engagement Δz_min below which the force stays at its Δz_min value [m] (fitted likewise).
        k_unload_n_per_m: Elastic unloading stiffness of the formed sheet [N/m] (`twin.process.force.table`).
        scale: Factor on Fz and F_xy [-] (1: the process's published level; a real cell's forces may differ,
            `twin.analysis.identify`).
        recovery_scale: Factor on the part's elastic recovery F/k_unload after unclamping [-] (1: the model's; it
            leaves the forces alone; identified from a scan, `twin.analysis.identify.springback`).
        depth_ratio: The part's depth after unclamping over its depth with that recovery [-] (1: no further loss;
            0.95: 5 % of the depth springs back; identified from a scan likewise).
        spacing_m: Height-map grid spacing [m].
        youngs_modulus_gpa: The sheet's E [GPa] (the wall's tilt, `twin.process.part.wall_tilt`).
        poisson_ratio: The sheet's ν [-], in (0, 0.5).
        hardening_k_mpa: K of the sheet's flow stress read as σ = K·ε^n [MPa]
            (`twin.process.material.hardening.power_law_equivalent`).
        hardening_n: n of it [-], in (0, 1].
        wall_tilt_scale: Factor on the wall's tilt when the tool's load is released [-] (1: the model's; 0: none,
            as for a material whose E the library does not know).
    """

    tensile_strength_mpa: float = 275.0
    thickness_m: float = 1.0e-3
    tool_radius_m: float = TOOL_RADIUS_M
    wall_angle_max_deg: float = 63.43
    build_up_m: float = 3.75e-3
    mu_eff: float = 0.103
    mu_radial: float = 0.227
    direction_length_m: float = 0.996e-3
    step_min_m: float = 0.2e-3
    k_unload_n_per_m: float = K_UNLOAD_N_PER_M
    scale: float = 1.0
    spacing_m: float = 0.5e-3
    recovery_scale: float = 1.0
    depth_ratio: float = 1.0
    # the thesis's AA5086-H111 (`models/materials/library.toml`): its Voce law read as a power law
    youngs_modulus_gpa: float = 71.0
    poisson_ratio: float = 0.33
    hardening_k_mpa: float = 434.6
    hardening_n: float = 0.127
    wall_tilt_scale: float = 1.0

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (isinstance(value, int | float) and math.isfinite(value) and (value > 0 or (
                    name in ("mu_radial", "wall_tilt_scale") and value == 0))):
                raise InputError(f"IsfForceParams.{name} = {value!r}: expected a finite number > 0")
        if not (self.poisson_ratio < 0.5 and self.hardening_n <= 1.0):
            raise InputError(f"IsfForceParams: poisson_ratio {self.poisson_ratio!r} must be < 0.5 and hardening_n "
                             f"{self.hardening_n!r} <= 1")
        if not 0.0 < self.wall_angle_max_deg < 90.0:
            raise InputError(f"IsfForceParams.wall_angle_max_deg = {self.wall_angle_max_deg!r}: expected (0, 90)")


def material_fz_n(params: IsfForceParams) -> float:
    """The params' Fz / (h_mm^0.09 · α · cos α): Aerens's coefficient times R_m, t and d_t, times `scale` [N]."""
    return (
        params.scale * AERENS_COEFFICIENT * params.tensile_strength_mpa * (1e3 * params.thickness_m) ** EXPONENT_THICKNESS
        * (2e3 * params.tool_radius_m) ** EXPONENT_TOOL
    )


def sheet_constants(process: Process) -> dict[str, float]:
    """The wall tilt's sheet constants for a process's material (the library's E, ν and flow stress read as a
    power law); `wall_tilt_scale` 0 for a material the library does not have, or whose E or flow stress it does
    not know (the tilt is then left out, not guessed)."""
    try:
        found = material(process.material)
    except InputError:
        return {"wall_tilt_scale": 0.0}
    power = power_law_equivalent(found.hardening, found.yield_strength_mpa, found.tensile_strength_mpa)
    if found.youngs_modulus_gpa is None or power is None:
        return {"wall_tilt_scale": 0.0}
    return {"youngs_modulus_gpa": found.youngs_modulus_gpa, "poisson_ratio": found.poisson_ratio or 0.33,
            "hardening_k_mpa": power[0], "hardening_n": power[1]}


def params_for(process: Process, **overrides: float) -> IsfForceParams:
    """The model's constants for a process: its R_m, t and R, its material's elastic and plastic constants
    (`sheet_constants`), the shipped shape constants (`overrides` replace any of them)."""
    base = IsfForceParams(
        tensile_strength_mpa=process.tensile_strength_mpa, thickness_m=process.thickness_m,
        tool_radius_m=process.tool_radius_m, **sheet_constants(process),
    )
    unknown = set(overrides) - set(vars(base))
    if unknown:
        raise InputError(f"unknown ISF force-model constant(s) {sorted(unknown)}; valid: {sorted(vars(base))}")
    return replace(base, **overrides) if overrides else base


def steady_fz_n(process: Process, step_down_m: float, wall_angle_deg: float) -> float:
    """The model's steady axial force on a wall formed contour by contour [N]: Aerens's Eq. 30 with the scallop
    height at the wall angle, capped at α_max as the model caps it (build-up done).

    Args:
        process: The sheet and tool.
        step_down_m: Step-down Δz [m].
        wall_angle_deg: Wall angle α [deg].
    """
    angle = min(wall_angle_deg, IsfForceParams().wall_angle_max_deg)
    return aerens_fz_n(process.tensile_strength_mpa, process.thickness_m, process.tool_radius_m, step_down_m, angle)


