"""The force model held to published measurements: each published part formed on the rigid machine, its axial
force beside the measured one (`tx200-twin force-validation`, docs/force-validation.md).

Each `Case` of `twin.apps.force_data` becomes the user's process (material, R_m, thickness, tool) and part
(a cone of its wall angle, step-down and first contour, or the thesis's groove), formed by the virtual rigid
CNC (`twin.lab.cnc.run_cnc`) with the `isf` force model. The steady axial force is the mean of the sensor's Fz
where the tool tip is deeper than `STEADY_DEPTH_M` (the build-up done to 98 %); parts deeper than
`FORMED_DEPTH_M` are formed to that depth only (the steady force does not change below it). A prediction is
inside when it lies within `TOLERANCE` of the measurement; every case outside is listed with the reasons the
model knows of (conditions beyond the formula's published range, a strength the source does not give).

The build-up depth D0 is the one constant fitted to these data (`fit_build_up`, to the BM3 depth curve): that
row is marked fitted; the steady forces are predicted.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from twin.apps.force_data import BuildUp, Case, Measurements, shipped_measurements
from twin.apps.springback_validation import ProfileResult, bm3_profile, profile_lines
from twin.base.signals import interp_rows
from twin.errors import ExtrapolationWarning
from twin.lab.cnc import run_cnc
from twin.process.description import Process
from twin.process.force.aerens import aerens_fz_n, validity_warnings
from twin.process.force.isf_params import IsfForceParams, steady_fz_n
from twin.process.material.file import material
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.process.toolpath.shapes import PartSpec, part_path

#: A prediction within this fraction of the measurement is inside.
TOLERANCE = 0.20
#: Depth below which the model's axial force is steady (4 D0: 98 % built up) [m].
STEADY_DEPTH_M = 15e-3
#: Deepest a part is formed for its steady force [m].
FORMED_DEPTH_M = 30e-3


@dataclass(frozen=True)
class BuildUpFit:
    """`fit_build_up`'s result.

    Attributes:
        depth_m: Build-up depth D0 [m].
        fz_steady_n: Steady force of the fitted curve [N].
        rms_n: RMS of the window means' misfit [N].
    """

    depth_m: float
    fz_steady_n: float
    rms_n: float


@dataclass(frozen=True)
class CaseResult:
    """A published case and the model's prediction.

    Attributes:
        case: The published case.
        tensile_strength_mpa: R_m the prediction used [MPa].
        steady_n: Model's steady axial force on the part [N] (None where none is published to compare).
        peak_n: Model's largest axial force on the part [N].
        error: (model - measured) / measured, of the steady force where published, else of the peak [-].
        inside: Whether |error| <= `TOLERANCE`.
        reasons: What the model knows lies outside its published range, or how its inputs were chosen.
    """

    case: Case
    tensile_strength_mpa: float
    steady_n: float | None
    peak_n: float
    error: float
    inside: bool
    reasons: tuple[str, ...]


@dataclass(frozen=True)
class TrendResult:
    """A published ratio and the model's.

    Attributes:
        key: The trend's name.
        published: The published ratio [-].
        model: The model's ratio under the same change [-].
    """

    key: str
    published: float
    model: float


@dataclass(frozen=True)
class Validation:
    """Everything the table shows."""

    measurements: Measurements
    cases: tuple[CaseResult, ...]
    trends: tuple[TrendResult, ...]
    build_up: BuildUpFit
    profile: ProfileResult | None = None


def fit_build_up(data: BuildUp) -> BuildUpFit:
    """Fit Fz(D) = F_s·(1 - exp(-D/D0)) to window means of a measured force over depth (least squares).

    The mean of the law over a window [a, b] is F_s·(1 - D0·(exp(-a/D0) - exp(-b/D0))/(b - a)).
    """
    a, b, f = data.depth_from_m, data.depth_to_m, data.fz_mean_n

    def means(v: np.ndarray) -> np.ndarray:
        fs, d0 = v[0], v[1] * 1e-3
        return np.asarray(fs * (1.0 - d0 * (np.exp(-a / d0) - np.exp(-b / d0)) / (b - a)))

    result = least_squares(lambda v: means(v) - f, x0=[float(f[-1]), 2.0], bounds=([1.0, 0.1], [1e5, 50.0]))
    rms = float(np.sqrt(np.mean(result.fun**2)))
    return BuildUpFit(depth_m=float(result.x[1]) * 1e-3, fz_steady_n=float(result.x[0]), rms_n=rms)


def _strength(case: Case) -> tuple[float, tuple[str, ...]]:
    if case.tensile_strength_mpa is not None:
        return case.tensile_strength_mpa, ()
    rm = material(case.material).tensile_strength_mpa
    return rm, (f"R_m {rm:g} MPa: the library's {case.material} (the source's strength was not read)",)


def _part(case: Case) -> ToolPath:
    if case.shape == "groove":
        return groove_path()
    return part_path(PartSpec(
        shape="cone", top_half_width_m=0.5 * (case.top_diameter_m or 0.1), depth_m=min(case.depth_m, FORMED_DEPTH_M),
        wall_angle_deg=case.wall_angle_deg, step_down_m=case.step_down_m,
        mode="z-level" if case.strategy.startswith("z-level") else "spiral",
    ))


def predict_case(case: Case, seed: int = 1) -> CaseResult:
    """Form the case's part on the rigid CNC with its process and compare the axial force (module docstring)."""
    rm, reasons = _strength(case)
    process = Process(material=case.material, tensile_strength_mpa=rm, thickness_m=case.thickness_m,
                      tool_radius_m=case.tool_radius_m, force_model="isf")
    notes = list(reasons)
    notes += validity_warnings(case.thickness_m, case.tool_radius_m, case.step_down_m, case.wall_angle_deg)
    if case.wall_angle_deg > IsfForceParams().wall_angle_max_deg:
        notes.append(f"the model caps the wall angle at {IsfForceParams().wall_angle_max_deg:g}° (Aerens's formula "
                     f"at {case.wall_angle_deg:g}° gives {_formula(process, case):.0f} N)")
    if case.shape == "groove":
        notes.append("a groove is no cone wall: the tool steps 1 mm straight down each pass and forms both flanks "
                     "(docs/forces.md)")
    path = _part(case)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)  # listed in `notes`
        run, truth = run_cnc(seed=seed, path=path, process=process)
    assert run.forces is not None
    depth = -interp_rows(run.forces.t_s, path.t_s, path.p_sheet_m)[:, 2]
    steady = None
    if case.fz_steady_n is not None:
        steady = float(np.mean(run.forces.values[depth >= min(STEADY_DEPTH_M, 0.6 * case.depth_m), 2]))
    peak = float(truth["peak_fz_n"])
    measured, model = (case.fz_steady_n, steady) if case.fz_steady_n is not None else (case.fz_peak_n, peak)
    assert measured is not None and model is not None
    error = (model - measured) / measured
    return CaseResult(case, rm, steady, peak, error, abs(error) <= TOLERANCE, tuple(notes))


def _formula(process: Process, case: Case) -> float:
    return aerens_fz_n(process.tensile_strength_mpa, process.thickness_m, process.tool_radius_m, case.step_down_m,
                       case.wall_angle_deg)


def validate_forces(measurements: Measurements | None = None, seed: int = 1) -> Validation:
    """Every case and trend of the measurements (default: the shipped ones) against the model."""
    data = measurements or shipped_measurements()
    cases = tuple(predict_case(c, seed) for c in data.cases)
    trends = []
    for t in data.trends:
        if t.condition != "thickness_mm":
            continue
        lo, hi = (Process(thickness_m=1e-3 * v, tool_radius_m=0.5e-3 * t.tool_diameter_mm) for v in
                  (t.from_value, t.to_value))
        trends.append(TrendResult(t.key, t.ratio, steady_fz_n(hi, 0.5e-3, 45.0) / steady_fz_n(lo, 0.5e-3, 45.0)))
    return Validation(data, cases, tuple(trends), fit_build_up(data.build_up), bm3_profile(seed))


def _n(value: float | None) -> str:
    return "—" if value is None else f"{value:.0f}"


def result_json(result: Validation) -> dict[str, Any]:
    """The validation's numbers as the `force-validation --json` document."""
    return {
        "cases": [{
            "key": r.case.key, "source": r.case.source, "material": r.case.material,
            "tensile_strength_mpa": r.tensile_strength_mpa, "measured_steady_n": r.case.fz_steady_n,
            "measured_peak_n": r.case.fz_peak_n, "model_steady_n": r.steady_n, "model_peak_n": r.peak_n,
            "error": r.error, "inside": r.inside, "reasons": list(r.reasons),
        } for r in result.cases],
        "trends": [{"key": t.key, "published": t.published, "model": t.model} for t in result.trends],
        "build_up": {"depth_mm": 1e3 * result.build_up.depth_m, "fz_steady_n": result.build_up.fz_steady_n,
                     "rms_n": result.build_up.rms_n},
    }


def markdown(validation: Validation) -> str:
    """The page docs/force-validation.md: sources, the table, trends, the build-up fit, what is missing."""
    data = validation.measurements
    inside = sum(r.inside for r in validation.cases)
    lines = [
        "# The force model against published measurements",
        "",
        "Generated by `tx200-twin force-validation --markdown docs/force-validation.md`; do not edit it by hand (a "
        "test compares it with a fresh run). Each published part is formed by the virtual rigid CNC with the `isf` "
        "force model and the source's process (`twin/apps/force_validation.py`); the measurements and their "
        "sources are `twin/data/force_measurements.toml`. Model columns are **predicted** (nothing in the force "
        "level is fitted to these data) except the build-up depth D0, **fitted** to the BM3 depth curve below.",
        "",
        f"**{inside} of {len(validation.cases)} cases lie within {TOLERANCE:.0%}** of the measurement "
        f"(steady axial force where published, else the peak), from {len({r.case.source for r in validation.cases})} "
        "independent sources.",
        "",
        "| case | material | R_m [MPa] | t [mm] | tool Ø [mm] | Δz [mm] | α [°] | part | measured steady / peak [N] "
        "| model steady / peak [N] | error | within 20 % |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in validation.cases:
        c = r.case
        approx = " (approx.)" if c.approximate else ""
        lines.append(
            f"| {c.key} | {c.material} | {r.tensile_strength_mpa:g} | {1e3 * c.thickness_m:g} | "
            f"{2e3 * c.tool_radius_m:g} | {1e3 * c.step_down_m:g} | {c.wall_angle_deg:g} | {c.shape}, {c.strategy} | "
            f"{_n(c.fz_steady_n)} / {_n(c.fz_peak_n)}{approx} | {_n(r.steady_n)} / {_n(r.peak_n)} | "
            f"{r.error:+.0%} | {'yes' if r.inside else '**no**'} |"
        )
    lines += ["", "## Where each number stands, and what the model knows about each case", ""]
    for r in validation.cases:
        src = data.sources[r.case.source]
        lines.append(f"- **{r.case.key}** ({src.citation}): {r.case.where}. R_m: {r.case.tensile_strength_source}.")
        lines += [f"  - {reason}" for reason in r.reasons]
    lines += ["", "## Trends", "",
              "The model's ratio under the same change (Aerens's exponents; the ratio does not depend on the step-down "
              "and wall angle the source leaves out).", "",
              "| trend | published ratio | model ratio | within 20 % | source |", "|---|---|---|---|---|"]
    for t, spec in zip(validation.trends, [t for t in data.trends if t.condition == "thickness_mm"], strict=True):
        agrees = abs(t.model / t.published - 1.0) <= TOLERANCE
        lines.append(f"| {t.key} ({spec.material}) | {t.published:.2f} | {t.model:.2f} | "
                     f"{'yes' if agrees else '**no**'} | {spec.where}; {spec.note} |")
    b, fit = data.build_up, validation.build_up
    lines += [
        "",
        "## Build-up with depth (fitted)",
        "",
        f"Fz(D) = F_s·(1 − exp(−D/D0)) fitted to the window means of the BM3 cone ({b.where}): **D0 = "
        f"{1e3 * fit.depth_m:.2f} mm**, F_s = {fit.fz_steady_n:.0f} N, rms misfit {fit.rms_n:.0f} N. Depths: {b.derived}. "
        f"The model uses D0 = {1e3 * IsfForceParams().build_up_m:.2f} mm (`twin.process.force.isf_params`).",
        "",
        "| depth [mm] | measured mean Fz [N] |",
        "|---|---|",
        *(f"| {1e3 * a:.1f}–{1e3 * z:.1f} | {f:.0f} |" for a, z, f in zip(b.depth_from_m, b.depth_to_m, b.fz_mean_n,
                                                                          strict=True)),
        "",
        *profile_lines(validation.profile),
        "## Sources",
        "",
        *(f"- `{s.key}`: {s.citation}. Group: {s.group}. Read: {s.read}." for s in data.sources.values()),
        "",
        "## What is missing",
        "",
        "Fewer published cases than a validation wants: the stored copies of the literature reachable here give the "
        "full text of few ISF force papers. Not read, and the first to add: Aerens et al. (IJAMT 46, 2010), their "
        "tables of measured cones and the DC01 depth curves; Duflou et al. (J Mater Process Technol 189, 2007), force "
        "against step-down, tool diameter, wall angle and thickness in AA3003-O; Henrard et al. (Comput Mech 47, "
        "2011), AA3003-O cones; Petek et al. (2009), DC05; Alsamhan et al. (PLoS One, 2019). A measured split of the "
        "in-plane force into radial and tangential parts was not found (the model's is Neto et al.'s FE). Adding a "
        "case is adding a `[[cases]]` table to `twin/data/force_measurements.toml` with its source.",
        "",
    ]
    return "\n".join(lines)
