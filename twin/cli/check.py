"""`tx200-twin check`: residual of a (compensated) run against the ideal path, and its effective gain."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from twin.analysis.check import GAIN_TOLERANCE, check_run
from twin.analysis.surface_check import read_target_mesh, surface_deviation
from twin.base.csvio import emit_json
from twin.cli._common import add_ideal_argument, ideal_from_arguments
from twin.errors import InputError
from twin.runs.read import read_run

HELP = "Check a run against the ideal path U_ID: residual per pass/direction and the compensation gain."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `check` options."""
    parser.add_argument("run_dir", type=Path, help="a tx200-twin-run/1 directory")
    add_ideal_argument(parser)
    parser.add_argument(
        "--target-stl",
        type=Path,
        metavar="FILE",
        help="target part mesh [mm] (e.g. `path --stl-out`): also compare the run's part scan with it (CAD-like)",
    )
    parser.add_argument("--figure", type=Path, metavar="PNG", help="with --target-stl: the deviation map")
    parser.add_argument("--json", help="write the numbers to FILE ('-' for stdout)")


def run(args: argparse.Namespace) -> int:
    """Check the run; exit code 1 when the gain is off by more than the tolerance."""
    ideal = ideal_from_arguments(args)
    measured = read_run(args.run_dir)
    result = check_run(measured, ideal.t_s, ideal.p_sheet_m)
    summary = {"run": args.run_dir, **result.summary()}
    line = (
        f"check {args.run_dir}: residual rms {summary['residual_rms_mm']:.3f} mm, "
        f"max {summary['residual_max_mm']:.3f} mm; {result.diagnosis}"
    )
    protect = [p for p in (args.run_dir, args.target_stl, args.ideal) if p is not None]
    if args.figure is not None and args.target_stl is None:
        raise InputError("--figure draws the surface deviation map: it needs --target-stl FILE")
    if args.target_stl is not None:
        if measured.part_scan is None:
            raise InputError(
                f"{args.run_dir} has no part_scan.csv: the CAD-like check needs a scan of the formed part "
                "(the labs write one for parts formed with the height-map model, --force-model isf/auto)"
            )
        deviation = surface_deviation(measured.part_scan, read_target_mesh(args.target_stl))
        summary.update(deviation.summary_mm())
        line += (
            f"; surface vs {args.target_stl.name}: rms {1e3 * deviation.rms_m:.3f} mm, "
            f"max {1e3 * deviation.max_abs_m:.3f} mm, mean {1e3 * deviation.mean_m:+.3f} mm "
            f"over {len(deviation.deviation_m)} scan points"
        )
        if args.figure is not None:
            from twin.viz.surface_figures import plot_surface_deviation

            summary["figure"] = plot_surface_deviation(args.figure, deviation, protect=protect)
    print(line, file=sys.stderr if args.json == "-" else sys.stdout)  # keep stdout pure JSON for `--json -`
    emit_json(args.json, summary, protect=protect)
    return 0 if abs(result.gain - 1.0) <= GAIN_TOLERANCE else 1
