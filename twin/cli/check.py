"""`tx200-twin check`: residual of a (compensated) run against the ideal path, and its effective gain; with
`--target-stl`, the formed part against its target or design mesh: the run's `part_scan.csv` or, with `--scan`, a
scanner's point cloud registered to the mesh, its deviations over the formed region and by region of the design
(`twin.apps.tasks.check`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.analysis.scan_registration import DATUMS, INLIER_M, MAX_RMS_M, MIN_INLIER_FRACTION
from twin.cli._common import add_ideal_argument, add_json_argument, finish, note
from twin.cli._types import finite
from twin.runs.scan_file import UNITS

HELP = ("Check a run against the ideal path U_ID: residual per pass/direction and the compensation gain, its cause "
        "named from the run's record of what its compensation used (`compensate` writes CMD.compensation.json, "
        "`lab --commanded CMD.csv` carries it into the run), else unknown; with --target-stl, the formed part "
        "against the mesh. The exit code judges what was asked: with --target-stl the part (0: within "
        "--part-tolerance-mm of the mesh, 1: outside), without it the path (0: the gain is within tolerance, or a "
        "nominal run; 1: a compensated run's gain is off); 2: bad input, or a command compensated to a design "
        "checked without it.")


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
    _add_scan_arguments(parser)
    parser.add_argument("--figure", type=Path, metavar="PNG", help="with --target-stl: the deviation map")
    parser.add_argument(
        "--part-tolerance-mm", type=finite, metavar="T",
        help="with --target-stl: the part passes when 99 %% of its formed region lies within T of the mesh (the "
        "drawing's profile tolerance; default 0.2) [mm]",
    )
    parser.add_argument(
        "--model", type=Path, metavar="FILE",
        help="a twin model file (`learn --write-model`): the tracker registration it carries (a rotation and a "
        "shift, learned from the cell's runs) is taken off the tracker before judging, and the report says so",
    )
    parser.add_argument(
        "--free-moves", action="store_true",
        help="without --model: fit the tracker's registration on the run's free moves (|F| < 20 N) and take it off "
        "(unloaded, the arm's own sag and following error look like a registration too)",
    )
    add_json_argument(parser, "the numbers")


def _add_scan_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the scan's options (`--scan`, its units, its registration to the mesh)."""
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


def run(args: argparse.Namespace) -> int:
    """Check the run (and its part); the exit code judges the part with a mesh, else the path's gain."""
    from twin.analysis.tracker_frame import TrackerRegistration
    from twin.apps.tasks.check import CheckRequest, check_task
    from twin.sim.model_file import read_model_file

    request = CheckRequest(args.run_dir, args.ideal, args.target_stl, args.scan, args.scan_units, args.register,
                           args.datum, args.fit_rms_mm, args.fit_fraction, args.figure, args.part_tolerance_mm,
                           free_moves=args.free_moves)
    registration = None if args.model is None else TrackerRegistration.from_instruments(
        read_model_file(args.model).effects.instruments, f"the model file {args.model}")
    return finish(args, check_task(request, note, registration),
                  protect=(args.run_dir, args.target_stl, args.ideal, args.scan, args.model))
