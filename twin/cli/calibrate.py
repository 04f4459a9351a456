"""`tx200-twin calibrate`: fit the twin's free physical parameters to the thesis's measurements
(`twin.apps.tasks.calibrate`)."""

from __future__ import annotations

import argparse

from twin.apps.tasks.base import silent
from twin.cli._common import add_json_argument, finish, note

HELP = "Calibrate K_q, joint friction and the sheet's sensitivities to the thesis's measured numbers."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--json FILE` (`-` for stdout), `--quiet` and `--loo`."""
    add_json_argument(parser, "the calibration")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    parser.add_argument(
        "--loo", action="store_true",
        help="also refit once per target without it and predict it (leave-one-out; about 3 minutes on 2 cores)",
    )


def run(args: argparse.Namespace) -> int:
    """Run the least-squares calibration (about 1–4 minutes on 2 cores) and report it (progress on stderr)."""
    from twin.apps.tasks.calibrate import CalibrateRequest, calibrate_task

    return finish(args, calibrate_task(CalibrateRequest(loo=args.loo), silent if args.quiet else note))
