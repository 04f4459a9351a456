"""`tx200-twin demo`: the thesis story end to end on the shipped data (what `make demo` runs)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.apps.demo import run_demo

HELP = (
    "Run the thesis story end to end (lab, replay, identify, compensate, check, discrepancy) with a report."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `demo` options."""
    parser.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder (default out/demo)")


def run(args: argparse.Namespace) -> int:
    """Run the demo."""
    run_demo(args.out)
    return 0
