"""`tx200-twin check`: residual of a (compensated) run against the ideal path, and its effective gain; with
`--target-stl`, the formed part against its target or design mesh: the run's `part_scan.csv` or, with `--scan`, a
scanner's point cloud (`twin.runs.scan_file`) registered to the mesh (`twin.analysis.scan_registration`), its
deviations over the formed region and by region of the design (`twin.analysis.surface_check`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.scan_registration import DATUMS, INLIER_M, MAX_RMS_M, MIN_INLIER_FRACTION, register_scan
from twin.analysis.surface_check import (
    REGIONS,
    DesignIndex,
    read_target_mesh,
    region_deviation,
    surface_deviation,
)
from twin.base.jsonio import emit_json
from twin.cli._common import add_ideal_argument, add_json_argument, ideal_from_arguments
from twin.cli._types import finite
from twin.errors import InputError
from twin.runs.format import Run
from twin.runs.read import read_run
from twin.runs.scan_file import UNITS, read_scan

HELP = ("Check a run against the ideal path U_ID: residual per pass/direction and the compensation gain, its cause "
        "named from the run's record of what its compensation used (`compensate` writes CMD.compensation.json, "
        "`lab --commanded CMD.csv` carries it into the run), else unknown. Exit 0: the gain is within tolerance, or "
        "a nominal run; 1: a compensated run's gain is off; 2: bad input.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `check` options."""
    parser.add_argument("run_dir", type=Path, help="a tx200-twin-run/1 directory")
    add_ideal_argument(parser)
    parser.add_argument(
        "--target-stl",
        type=Path,
        metavar="FILE",
        help="target or design part mesh [mm] (`path --stl-out` or `--design-stl`): also compare the run's part "
        "scan (or --scan) with it (CAD-like), by region",
    )
    parser.add_argument(
        "--scan",
        type=Path,
        metavar="FILE",
        help="with --target-stl: a scanner's point cloud of the part (.ply, .xyz, .csv; scanner frame) instead of "
        "the run's part_scan.csv, registered to the mesh",
    )
    parser.add_argument("--scan-units", choices=tuple(UNITS), help="units of --scan (default mm, or its CSV's)")
    parser.add_argument(
        "--register", action="store_true", help="register the run's part_scan.csv too (it is in the sheet frame)"
    )
    parser.add_argument(
        "--datum", choices=DATUMS, default=DATUMS[0],
        help="registration: the flat sheet fixes height and tilts (sheet, default), or a best fit of all points",
    )
    parser.add_argument(
        "--fit-rms-mm", type=finite, default=MAX_RMS_M * 1e3,
        help=f"refuse a registered scan whose best-fit rms exceeds this (default {MAX_RMS_M * 1e3:g}) [mm]",
    )
    parser.add_argument(
        "--fit-fraction", type=finite, default=MIN_INLIER_FRACTION,
        help=f"... or with fewer of its points within {INLIER_M * 1e3:g} mm (default {MIN_INLIER_FRACTION:g})",
    )
    parser.add_argument("--figure", type=Path, metavar="PNG", help="with --target-stl: the deviation map")
    add_json_argument(parser, "the numbers")


def run(args: argparse.Namespace) -> int:
    """Check the run; exit code 1 when a compensated run's gain is off by more than the tolerance (0 for a
    nominal run, whose command is the ideal path)."""
    from twin.analysis.check import GAIN_TOLERANCE, check_run

    needs = [name for name, on in (("--figure", args.figure), ("--scan", args.scan), ("--register", args.register))
             if on]
    if needs and args.target_stl is None:
        raise InputError(f"{', '.join(needs)} compare(s) the part with a mesh: it needs --target-stl FILE")
    if args.scan_units is not None and args.scan is None:
        raise InputError("--scan-units gives the units of --scan FILE; the run's part_scan.csv declares its own")
    ideal = ideal_from_arguments(args)
    measured = read_run(args.run_dir)
    name = f"--ideal {args.ideal}" if args.ideal is not None else "the default ideal path (the groove; --ideal FILE)"
    result = check_run(measured, ideal.t_s, ideal.p_sheet_m, name)
    summary = {"run": args.run_dir, **result.summary()}
    line = (
        f"check {args.run_dir}: residual rms {summary['residual_rms_mm']:.3f} mm, "
        f"max {summary['residual_max_mm']:.3f} mm; {result.diagnosis}"
    )
    protect = [p for p in (args.run_dir, args.target_stl, args.ideal, args.scan) if p is not None]
    if args.target_stl is not None:
        line += _surface(args, measured, summary, protect)
    print(line, file=sys.stderr if args.json == "-" else sys.stdout)  # keep stdout pure JSON for `--json -`
    emit_json(args.json, summary, protect=protect)
    return 0 if result.nominal or abs(result.gain - 1.0) <= GAIN_TOLERANCE else 1


def _surface(args: argparse.Namespace, measured: Run, summary: dict[str, Any], protect: list[Path]) -> str:
    """The CAD-like check: the scan (registered if asked) against the mesh; fills `summary`, returns a line."""
    if args.scan is not None:
        points, source = read_scan(args.scan, args.scan_units), args.scan.name
    elif measured.part_scan is None:
        raise InputError(
            f"{args.run_dir} has no part_scan.csv: the CAD-like check needs a scan of the formed part "
            "(--scan FILE, or a lab run formed with the height-map model, --force-model isf/auto)"
        )
    else:
        points, source = np.asarray(measured.part_scan), "part_scan.csv"
    index = DesignIndex(read_target_mesh(args.target_stl))
    registration = None
    text = ""
    if args.scan is not None or args.register:
        registration = register_scan(points, index, datum=args.datum, max_rms_m=args.fit_rms_mm / 1e3,
                                     min_inlier_fraction=args.fit_fraction)
        points = registration.apply(points)
        summary.update(registration.summary_mm())
        angles = ", ".join(f"{v:+.3f}" for v in registration.rotation_deg)
        shift = ", ".join(f"{v:+.3f}" for v in registration.translation_m * 1e3)
        free = f", free: {', '.join(registration.free)}" if registration.free else ""
        text = (f"; {source} registered ({registration.datum} datum): rotation x, y, z [{angles}] deg, translation "
                f"[{shift}] mm, best-fit rms {registration.residual_rms_m * 1e3:.3f} mm{free}")
    deviation = surface_deviation(points, index.mesh)
    regions = region_deviation(points, index)
    stats = regions.stats_mm()
    summary.update(deviation.summary_mm())
    summary["surface_regions"] = stats
    text += (
        f"; {source} vs {args.target_stl.name}: rms {1e3 * deviation.rms_m:.3f} mm, "
        f"max {1e3 * deviation.max_abs_m:.3f} mm, mean {1e3 * deviation.mean_m:+.3f} mm "
        f"over {len(deviation.deviation_m)} points of the formed region; "
        + ", ".join(f"{name} rms {stats[name]['rms_mm']:.3f} / mean {stats[name]['mean_mm']:+.3f} mm"
                    for name in REGIONS if name in stats)
    )
    if args.figure is not None:
        from twin.viz.surface_figures import plot_surface_deviation

        summary["figure"] = plot_surface_deviation(args.figure, deviation, regions=regions,
                                                   registration=registration, protect=protect)
    return text
