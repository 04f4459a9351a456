"""The springback model held to a published measured part: the NUMISHEET 2014 benchmark 3 cone's section (Neto
et al., Int J Adv Manuf Technol 85 (2016), Fig. 10; `twin/data/bm3_profile_rd.csv`) beside the part the model
forms on the rigid CNC with that process and unclamps (`twin.lab.cnc.run_cnc`: the elastic recovery F/k_unload
and the floating bottom). A section of `docs/force-validation.md` (`twin.apps.force_validation`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from twin.base.resources import data_file
from twin.errors import ExtrapolationWarning
from twin.lab.cnc import run_cnc
from twin.process.description import Process
from twin.process.toolpath.groove import ToolPath
from twin.process.toolpath.shapes import PartSpec, part_path


@dataclass(frozen=True)
class ProfileResult:
    """The BM3 part's measured section beside the model's, formed on the rigid machine and unclamped [mm].

    Attributes:
        x_mm: Where the measured section has points.
        measured_mm: Measured z there.
        model_mm: The model's z there (its part scan within 0.6 mm of the section).
        cad_depth_mm: The design's depth.
    """

    x_mm: np.ndarray
    measured_mm: np.ndarray
    model_mm: np.ndarray
    cad_depth_mm: float

    def rms_mm(self, inside_mm: float = 1e9) -> float:
        """RMS of model - measured over |x| <= `inside_mm`."""
        keep = np.isfinite(self.model_mm) & (np.abs(self.x_mm) <= inside_mm)
        return float(np.sqrt(np.mean((self.model_mm[keep] - self.measured_mm[keep]) ** 2)))


def bm3_measured() -> tuple[np.ndarray, float]:
    """The BM3 section as measured, (x, z) [mm] shape (m, 2), and the design's depth [mm]
    (`twin/data/bm3_profile_rd.csv`)."""
    table = [line.split(",") for line in data_file("bm3_profile_rd.csv").read_text().splitlines()
             if line and not line.startswith("#")][1:]
    measured = np.array([[float(x), float(z)] for series, x, z in table if series == "measured"])
    return measured, -min(float(z) for series, _, z in table if series == "cad")


def bm3_part(cad_depth_mm: float) -> tuple[Process, ToolPath]:
    """The BM3 cone's process (AA7075-O, 1.63 mm, Ø 12.66 mm, the `isf` model) and its z-level path, 0.5 mm down."""
    process = Process(material="AA7075-O", tensile_strength_mpa=198.0, thickness_m=1.63e-3, tool_radius_m=6.33e-3,
                      force_model="isf")
    return process, part_path(PartSpec(shape="cone", top_half_width_m=0.062, depth_m=1e-3 * cad_depth_mm,
                                       step_down_m=0.5e-3, mode="z-level"))


def bm3_profile(seed: int = 1) -> ProfileResult:
    """The BM3 cone (Neto et al. 2016, Fig. 10, `twin/data/bm3_profile_rd.csv`) formed on the rigid CNC with its
    process and unclamped (the model's elastic recovery and floating bottom), its section along x beside the
    measured one."""
    measured, cad_depth = bm3_measured()
    process, path = bm3_part(cad_depth)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        run, _ = run_cnc(seed=seed, path=path, process=process)
    assert run.part_scan is not None
    section = run.part_scan[np.abs(run.part_scan[:, 1]) < 0.6e-3]
    # the scan's rows either side of the section line averaged at each x: sorted with its ties, the section's
    # order would be the sort kernel's (numpy's SIMD sorts order ties by the machine: 0.1 mm at the rim)
    x_s, at = np.unique(section[:, 0], return_inverse=True)
    z_s = np.bincount(at, weights=section[:, 2]) / np.bincount(at)
    model = 1e3 * np.interp(1e-3 * measured[:, 0], x_s, z_s, left=np.nan, right=np.nan)
    return ProfileResult(measured[:, 0], measured[:, 1], model, cad_depth)


def profile_lines(profile: ProfileResult | None) -> list[str]:
    """The springback section of the page."""
    if profile is None:
        return []
    x, meas, model = profile.x_mm, profile.measured_mm, profile.model_mm
    rim = float(np.mean([np.interp(xi, x, model) - np.interp(xi, x, meas) for xi in (-60.0, 60.0)]))
    inner = np.array([np.interp(xi, x, meas) - np.interp(xi, x, model) for xi in (-40.0, -20.0, 0.0, 20.0, 40.0)])
    rows = [f"| {xi:+.0f} | {np.interp(xi, x, meas):.2f} | {np.interp(xi, x, model):.2f} |"
            for xi in (-60.0, -40.0, -20.0, 0.0, 20.0, 40.0, 60.0)]
    return [
        "## Springback: the BM3 part's section (predicted)",
        "",
        "The BM3 cone formed on the rigid CNC with its process and unclamped (the model's elastic recovery F/k_unload "
        "with k_unload calibrated on the thesis's AA5086 groove, the floating bottom, and the wall's tilt fitted on "
        "scanned cones, docs/springback.md), its section along x beside "
        "the measured one (Neto et al. 2016, Fig. 10, rolling direction, digitised by a third party: secondary; "
        f"`twin/data/bm3_profile_rd.csv`). The design is {profile.cad_depth_mm:.2f} mm deep. RMS model − measured: "
        f"**{profile.rms_mm():.2f} mm** over the section, {profile.rms_mm(50.0):.2f} mm within |x| ≤ 50 mm.",
        "",
        "| x [mm] | measured z [mm] | model z [mm] |",
        "|---|---|---|",
        *rows,
        "",
        f"Where the model is weak: near the clamp (|x| = 60 mm) the measured sheet lies {rim:.1f} mm lower than the "
        "model's (the unformed sheet bends there; the height map keeps it flat); the walls and the bottom come out "
        f"between {inner.min():+.1f} and {inner.max():+.1f} mm deeper than measured (the recovery's k_unload is a 1 mm "
        "AA5086 groove's, not this 1.63 mm AA7075-O part's).",
        "",
    ]
