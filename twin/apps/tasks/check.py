"""`check`: a (compensated) run against the ideal path U_ID, its residual per pass and direction and its
compensation gain, the gain's cause named from the run's record of what its compensation used
(`twin.analysis.check`); with a design or target mesh, the formed part against it: the run's `part_scan.csv` or a
scanner's point cloud (`twin.runs.scan_file`) registered to the mesh (`twin.analysis.scan_registration`), its
deviations over the formed region and by region of the design (`twin.analysis.surface_check`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.check import GAIN_TOLERANCE, CheckResult, check_run
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
    read_target_mesh,
    region_deviation,
    surface_deviation,
)
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.inputs import ideal_path
from twin.errors import InputError
from twin.runs.format import Run
from twin.runs.read import read_run
from twin.runs.scan_file import UNITS, read_scan


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

    def __post_init__(self) -> None:
        needs = [name for name, on in (("--figure", self.figure), ("--scan", self.scan), ("--register", self.register))
                 if on]
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
        record = {**registered, **self.deviation.summary_mm(), "surface_regions": self.regions.stats_mm()}
        return record if self.figure is None else {**record, "figure": self.figure}


@dataclass(frozen=True)
class CheckReport(Report):
    """A run checked against the ideal path (and its part against its mesh).

    Attributes:
        run_dir: The run checked.
        result: Its residual, gain and diagnosis.
        surface: The part against the mesh, or None.
    """

    run_dir: Path
    result: CheckResult
    surface: SurfaceCheck | None = None

    def lines(self) -> list[str]:
        m = self.result.summary()
        line = (f"check {self.run_dir}: residual rms {m['residual_rms_mm']:.3f} mm, max {m['residual_max_mm']:.3f} mm; "
                f"{self.result.diagnosis}")
        return [line if self.surface is None else line + self.surface.text()]

    def record(self) -> dict[str, Any]:
        surface = {} if self.surface is None else self.surface.record()
        return {"run": self.run_dir, **self.result.summary(), **surface}

    @property
    def exit_code(self) -> int:
        """1 when a compensated run's gain is off by more than `GAIN_TOLERANCE` (0 for a nominal run, whose
        command is the ideal path)."""
        return 0 if self.result.nominal or abs(self.result.gain - 1.0) <= GAIN_TOLERANCE else 1


def check_task(request: CheckRequest, note: Note = silent) -> CheckReport:
    """Check the run against the ideal path, and its part against the mesh when the request names one.

    Raises:
        PathMismatchError: The run's command does not follow the ideal path.
        InputError: No scan of the part to compare, a scan that does not fit the mesh.
        DataFileError, RunFormatError: A bad path, run, mesh or scan file (naming the file).
    """
    ideal = ideal_path(request.ideal)
    measured = read_run(request.run_dir)
    name = (f"--ideal {request.ideal}" if request.ideal is not None
            else "the default ideal path (the groove; --ideal FILE)")
    result = check_run(measured, ideal.t_s, ideal.p_sheet_m, name)
    surface = None if request.target_stl is None else _surface(request, request.target_stl, measured)
    return CheckReport(request.run_dir, result, surface)


def _surface(request: CheckRequest, target: Path, measured: Run) -> SurfaceCheck:
    """The CAD-like check: the scan (registered if asked) against the mesh."""
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
    registration = None
    if request.scan is not None or request.register:
        registration = register_scan(points, index, datum=request.datum, max_rms_m=request.fit_rms_mm / 1e3,
                                     min_inlier_fraction=request.fit_fraction)
        points = registration.apply(points)
    deviation = surface_deviation(points, index.mesh)
    regions = region_deviation(points, index)
    figure = None
    if request.figure is not None:
        from twin.viz.surface_figures import plot_surface_deviation

        protect = [p for p in (request.run_dir, target, request.ideal, request.scan) if p is not None]
        figure = plot_surface_deviation(request.figure, deviation, regions=regions, registration=registration,
                                        protect=protect)
    return SurfaceCheck(source, target, registration, deviation, regions, figure)
