"""`tx200-twin reproduce`: run the commands a new user would, and tabulate thesis vs twin
(`twin.apps.tasks.reproduce`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.cli._common import add_json_argument, finish, note

HELP = "Reproduce the thesis's numbers with the twin's own commands; write the table (Markdown)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `reproduce` options."""
    parser.add_argument("--work", type=Path, help="folder for the commands' outputs (default: a temporary one)")
    parser.add_argument("--markdown", type=Path, help="write the table as a Markdown document to FILE")
    parser.add_argument(
        "--calibration", type=Path, metavar="FILE",
        help="a `tx200-twin calibrate --loo --json FILE` output (e.g. docs/calibration.json): mark the fitted rows "
        "with their leave-one-out predictions",
    )
    add_json_argument(parser, "the rows")


def run(args: argparse.Namespace) -> int:
    """Run the commands, build the table and write it where asked."""
    from twin.apps.tasks.reproduce import ReproduceRequest, reproduce_task
    from twin.cli import main

    request = ReproduceRequest(args.work, args.markdown, args.calibration)
    return finish(args, reproduce_task(request, main, note), protect=(args.calibration,))
