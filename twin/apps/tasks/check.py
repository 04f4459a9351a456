"""`check`: a (compensated) run against the ideal path U_ID, its residual per pass and direction and its
compensation gain, the gain's cause named from the run's record of what its compensation used
(`twin.analysis.check`), judged on the tracker with its registration error taken off where one is known (a model
file's, or with `free_moves` one fitted on the run's free moves, `twin.analysis.tracker_frame`); with a design or
target mesh, the formed part against it: the run's `part_scan.csv` or a
scanner's point cloud (`twin.runs.scan_file`) registered to the mesh (`twin.analysis.scan_registration`), its
deviations over the formed region and by region of the design (`twin.analysis.surface_check`).

What it judges (its exit code) is what was asked. With a mesh, the part: it passes when its deviation from the
mesh is within `part_tolerance_mm` (`PART_QUANTILE` of |deviation| over the formed region, so that one stray scan
point does not fail a part), whatever the path did: a springback-compensated command leaves the ideal path on
purpose. Without one, the path: a compensated run's gain within `GAIN_TOLERANCE`. A run whose command was
compensated to a design (its compensation record names the design) is refused without a mesh: its path is not
meant to follow the ideal one, and judging it would fail a good part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.check import GAIN_TOLERANCE, CheckResult, check_run
from twin.analysis.compensation_record import run_record
from twin.analysis.scan_registration import (
    DATUMS,
    MAX_RMS_M,
    MIN_INLIER_FRACTION,
    ScanRegistration,
    register_scan,
)
from twin.analysis.surface_check import (
    REGIONS,
    DesignIndex,
    RegionDeviation,
    SurfaceDeviation,
    deviations,
    read_target_mesh,
)
from twin.analysis.tracker_frame import FREE_FORCE_N, TrackerRegistration, fit_on_free_moves
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.inputs import ideal_path
from twin.errors import InputError
from twin.process.part.match import check_same_part
from twin.runs.format import Run
from twin.runs.read import read_run
from twin.runs.scan_file import UNITS, read_scan

#: The part's default profile tolerance [mm]: ours, chosen before any part was measured against it (a sheet-metal
#: drawing's general tolerance is of this order); a drawing's own is given with `--part-tolerance-mm`.
DEFAULT_PART_TOLERANCE_MM = 0.2
#: The share of the formed region's points that must lie within the tolerance (a scan's stray points aside).
PART_QUANTILE = 0.99


@dataclass(frozen=True)
class CheckRequest:
    """What to check.

    Attributes:
        run_dir: A tx200-twin-run/1 folder.
        ideal: The ideal path U_ID (CSV t_s, x_mm, y_mm, z_mm), or None for the groove.
        target_stl: A target or design part mesh [mm]: also compare the part's scan with it, or None.
        scan: With `target_stl`: a scanner's point cloud of the part (.ply, .xyz, .csv; scanner frame) instead of
            the run's part_scan.csv, registered to the mesh.
        scan_units: The units of `scan` (`twin.runs.scan_file.UNITS`), or None (mm, or its CSV's).
        register: Register the run's part_scan.csv too (it is in the sheet frame).
        datum: Registration: "sheet" (the flat sheet fixes height and tilts) or "best-fit" (of all points).
        fit_rms_mm: Refuse a registered scan whose best-fit rms exceeds this [mm].
        fit_fraction: ... or with a smaller share of its points fitting [-].
        figure: With `target_stl`: the deviation map to write (PNG), or None.
        part_tolerance_mm: With `target_stl`: the part passes when `PART_QUANTILE` of its |deviation| from the
            mesh is within this [mm] (the drawing's profile tolerance; `DEFAULT_PART_TOLERANCE_MM` is ours).
        free_moves: Fit the tracker's registration on the run's free moves and take it off (where no model gives
            one). Off by default: unloaded, the tip also misses the command by the arm's own sag and following
            error, which the fit would take for the tracker's (0.16 mm on a quasi-static lab cone, whose tracker
            is perfect).
    """

    run_dir: Path
    ideal: Path | None = None
    target_stl: Path | None = None
    scan: Path | None = None
    scan_units: str | None = None
    register: bool = False
    datum: str = DATUMS[0]
    fit_rms_mm: float = MAX_RMS_M * 1e3
    fit_fraction: float = MIN_INLIER_FRACTION
    figure: Path | None = None
    part_tolerance_mm: float | None = None
    free_moves: bool = False

    def __post_init__(self) -> None:
        needs = [name for name, on in (("--figure", self.figure), ("--scan", self.scan), ("--register", self.register),
                                       ("--part-tolerance-mm", self.part_tolerance_mm is not None)) if on]
        tol = self.part_tolerance_mm
        if tol is not None and not (math.isfinite(tol) and 0.0 < tol <= 10.0):
            raise InputError(f"--part-tolerance-mm {tol!r}: expected the part's profile tolerance, > 0 and <= 10 mm")
        if needs and self.target_stl is None:
            raise InputError(f"{', '.join(needs)} compare(s) the part with a mesh: it needs --target-stl FILE")
        if self.scan_units is not None and self.scan is None:
            raise InputError("--scan-units gives the units of --scan FILE; the run's part_scan.csv declares its own")
        for option, value, valid in (("--scan-units", self.scan_units, (None, *UNITS)), ("--datum", self.datum, DATUMS)):
            if value not in valid:
                raise InputError(f"{option} {value!r}: expected one of {', '.join(v for v in valid if v)}")


@dataclass(frozen=True)
class SurfaceCheck:
    """The formed part against its mesh.

    Attributes:
        source: The scan compared: "part_scan.csv" or the scan file's name.
        target: The mesh file.
        registration: The scan's registration to the mesh, or None (the run's part_scan.csv as it is).
        deviation: Its deviation over the formed region.
        regions: Its deviation by region of the design.
        figure: The deviation map written, or None.
    """

    source: str
    target: Path
    registration: ScanRegistration | None
    deviation: SurfaceDeviation
    regions: RegionDeviation
    figure: Path | None = None
    tolerance_mm: float = DEFAULT_PART_TOLERANCE_MM

    @property
    def quantile_mm(self) -> float:
        """`PART_QUANTILE` of |deviation| over the formed region [mm]."""
        return float(1e3 * np.quantile(np.abs(self.deviation.deviation_m), PART_QUANTILE))

    @property
    def within(self) -> bool:
        """The part is within its tolerance of the mesh."""
        return self.quantile_mm <= self.tolerance_mm

    def verdict(self) -> str:
        """The judgement's words."""
        word = "within" if self.within else "OUTSIDE"
        return (f"judged: the part against {self.target.name}: {100 * PART_QUANTILE:g} % of its points within "
                f"{self.quantile_mm:.3f} mm, {word} the tolerance {self.tolerance_mm:g} mm")

    def text(self) -> str:
        """What the summary line says of it, from its leading "; "."""
        text, reg = "", self.registration
        if reg is not None:
            angles = ", ".join(f"{v:+.3f}" for v in reg.rotation_deg)
            shift = ", ".join(f"{v:+.3f}" for v in reg.translation_m * 1e3)
            free = f", free: {', '.join(reg.free)}" if reg.free else ""
            text = (f"; {self.source} registered ({reg.datum} datum): rotation x, y, z [{angles}] deg, translation "
                    f"[{shift}] mm, best-fit rms {reg.residual_rms_m * 1e3:.3f} mm{free}")
        d, stats = self.deviation, self.regions.stats_mm()
        return text + (
            f"; {self.source} vs {self.target.name}: rms {1e3 * d.rms_m:.3f} mm, max {1e3 * d.max_abs_m:.3f} mm, "
            f"mean {1e3 * d.mean_m:+.3f} mm over {len(d.deviation_m)} points of the formed region; "
            + ", ".join(f"{name} rms {stats[name]['rms_mm']:.3f} / mean {stats[name]['mean_mm']:+.3f} mm"
                        for name in REGIONS if name in stats)
        )

    def record(self) -> dict[str, Any]:
        """Its numbers, under the keys of `check --json` [mm]."""
        registered = {} if self.registration is None else self.registration.summary_mm()
        record = {**registered, **self.deviation.summary_mm(), "surface_regions": self.regions.stats_mm(),
                  "part_quantile_mm": self.quantile_mm, "part_tolerance_mm": self.tolerance_mm,
                  "part_within_tolerance": self.within}
        return record if self.figure is None else {**record, "figure": self.figure}


@dataclass(frozen=True)
class CheckReport(Report):
    """A run checked against the ideal path (and its part against its mesh).

    Attributes:
        run_dir: The run checked.
        result: Its residual, gain and diagnosis.
        surface: The part against the mesh, or None.
        registration_note: Why no tracker registration was taken off, or None (one was, or it was kept on purpose).
    """

    run_dir: Path
    result: CheckResult
    surface: SurfaceCheck | None = None
    registration_note: str | None = None

    def lines(self) -> list[str]:
        m = self.result.summary()
        split = (f" ({m['residual_along_path_rms_mm']:.3f} along the path, {m['residual_across_path_rms_mm']:.3f} "
                 "across it)" if "residual_along_path_rms_mm" in m else "")
        line = (f"check {self.run_dir}: residual rms {m['residual_rms_mm']:.3f} mm{split}, max "
                f"{m['residual_max_mm']:.3f} mm; {self.result.diagnosis}")
        registration = self.result.registration
        said = [registration.text() if registration is not None else self.registration_note]
        if self.surface is None:
            judged = ("judged: the path (a nominal run: nothing to judge)" if self.result.nominal else
                      f"judged: the path's gain {self.result.gain:.3f}, "
                      f"{'within' if self.exit_code == 0 else 'OUTSIDE'} 1 +- {GAIN_TOLERANCE:g}")
            return [line, *(s for s in said if s), judged]
        return [line + self.surface.text(), *(s for s in said if s), self.surface.verdict()]

    def record(self) -> dict[str, Any]:
        surface = {} if self.surface is None else self.surface.record()
        note = {} if self.registration_note is None else {"tracker_registration_note": self.registration_note}
        return {"run": self.run_dir, **self.result.summary(), **note, **surface, "judged": self.judged}

    @property
    def judged(self) -> str:
        """What the exit code judges: "part" (against the mesh) or "path" (the compensation's gain)."""
        return "path" if self.surface is None else "part"

    @property
    def exit_code(self) -> int:
        """With a mesh: 1 when the part is outside its tolerance of it. Without: 1 when a compensated run's gain is
        off by more than `GAIN_TOLERANCE` (0 for a nominal run, whose command is the ideal path)."""
        if self.surface is not None:
            return 0 if self.surface.within else 1
        return 0 if self.result.nominal or abs(self.result.gain - 1.0) <= GAIN_TOLERANCE else 1


#: What the report says when the run's free moves fix no tracker registration.
NO_REGISTRATION = ("tracker registration: none taken off (the run's free moves, |F| < {force:g} N, are too few or "
                   "in one direction only to fix it): the tracker is judged as it reads")


def check_task(request: CheckRequest, note: Note = silent,
               registration: TrackerRegistration | None = None) -> CheckReport:
    """Check the run against the ideal path, and its part against the mesh when the request names one.

    The tracker's registration error is taken off before judging: `registration` when given (a model file's),
    else with `request.free_moves` one fitted on the run's free moves when they fix them; else none.

    Raises:
        PathMismatchError: The run's command does not follow the ideal path.
        InputError: No scan of the part to compare, a scan that does not fit the mesh.
        DataFileError, RunFormatError: A bad path, run, mesh or scan file (naming the file).
    """
    ideal = ideal_path(request.ideal)
    measured = read_run(request.run_dir)
    record = run_record(measured.meta, Path(request.run_dir) / "meta.json")
    if request.target_stl is None and record is not None and record.design_file is not None:
        raise InputError(
            f"{request.run_dir}: its command was compensated to the design {record.design_file} (compensate "
            "--target-stl): its path leaves the ideal path on purpose, so its gain is no verdict; judge the part "
            f"with --target-stl {record.design_file}")
    name = (f"--ideal {request.ideal}" if request.ideal is not None
            else "the default ideal path (the groove; --ideal FILE)")
    said = None
    if registration is None and request.free_moves:
        registration = fit_on_free_moves(measured)
        said = None if registration is not None else NO_REGISTRATION.format(force=FREE_FORCE_N)
    result = check_run(measured, ideal.t_s, ideal.p_sheet_m, name, registration=registration)
    surface = None if request.target_stl is None else _surface(request, request.target_stl, measured, ideal.p_sheet_m)
    return CheckReport(request.run_dir, result, surface, said)


def _surface(request: CheckRequest, target: Path, measured: Run, ideal_m: np.ndarray) -> SurfaceCheck:
    """The CAD-like check: the scan (registered if asked) against the mesh, both first checked to be the ideal
    path's part (not the run's command: a springback-compensated one runs deeper on purpose)."""
    if request.scan is not None:
        points, source = read_scan(request.scan, request.scan_units), request.scan.name
    elif measured.part_scan is None:
        raise InputError(
            f"{request.run_dir} has no part_scan.csv: the CAD-like check needs a scan of the formed part "
            "(--scan FILE, or a lab run formed with the height-map model, --force-model isf/auto)"
        )
    else:
        points, source = np.asarray(measured.part_scan), "part_scan.csv"
    index = DesignIndex(read_target_mesh(target))
    of_run = "the default ideal path (the groove)" if request.ideal is None else f"--ideal {request.ideal}"
    check_same_part(ideal_m, index.mesh, f"--target-stl {target}", path_what=of_run)
    registration = None
    if request.scan is not None or request.register:
        registration = register_scan(points, index, datum=request.datum, max_rms_m=request.fit_rms_mm / 1e3,
                                     min_inlier_fraction=request.fit_fraction)
        points = registration.apply(points)
    check_same_part(ideal_m, points, f"the scan {source}", path_what=of_run)
    deviation, regions = deviations(points, index)
    figure = None
    if request.figure is not None:
        from twin.viz.surface_figures import plot_surface_deviation

        protect = [p for p in (request.run_dir, target, request.ideal, request.scan) if p is not None]
        figure = plot_surface_deviation(request.figure, deviation, regions=regions, registration=registration,
                                        protect=protect)
    tolerance = DEFAULT_PART_TOLERANCE_MM if request.part_tolerance_mm is None else request.part_tolerance_mm
    return SurfaceCheck(source, target, registration, deviation, regions, figure, tolerance)
