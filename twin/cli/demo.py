"""`tx200-twin demo`: the thesis story end to end on the shipped data (what `make demo` runs)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.apps.readme import DEMO_BLOCK, demo_table

HELP = (
    "Run the thesis story end to end (lab, replay, identify, compensate, check, discrepancy) with a report."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `demo` options."""
    parser.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder (default out/demo)")
    parser.add_argument("--readme", type=Path, help="also write the demo's table into FILE's generated block")


def run(args: argparse.Namespace) -> int:
    """Run the demo."""
    from twin.apps.demo import run_demo

    report = run_demo(args.out)
    if args.readme is not None:
        DEMO_BLOCK.update(args.readme, demo_table(report))
        print(f"demo table -> {args.readme}")
    return 0
