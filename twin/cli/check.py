"""`tx200-twin check`: residual of a (compensated) run against the ideal path, and its effective gain."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from twin.analysis.check import GAIN_TOLERANCE, check_run
from twin.base.csvio import emit_json
from twin.cli._common import add_ideal_argument, ideal_from_arguments
from twin.runs.read import read_run

HELP = "Check a run against the ideal path U_ID: residual per pass/direction and the compensation gain."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `check` options."""
    parser.add_argument("run_dir", type=Path, help="a tx200-twin-run/1 directory")
    add_ideal_argument(parser)
    parser.add_argument("--json", help="write the numbers to FILE ('-' for stdout)")


def run(args: argparse.Namespace) -> int:
    """Check the run; exit code 1 when the gain is off by more than the tolerance."""
    ideal = ideal_from_arguments(args)
    result = check_run(read_run(args.run_dir), ideal.t_s, ideal.p_sheet_m)
    summary = {"run": args.run_dir, **result.summary()}
    print(
        f"check {args.run_dir}: residual rms {summary['residual_rms_mm']:.3f} mm, "
        f"max {summary['residual_max_mm']:.3f} mm; {result.diagnosis}",
        file=sys.stderr if args.json == "-" else sys.stdout,  # keep stdout pure JSON for `--json -`
    )
    emit_json(args.json, summary, protect=[args.run_dir])
    return 0 if abs(result.gain - 1.0) <= GAIN_TOLERANCE else 1
