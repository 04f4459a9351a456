"""`tx200-twin bench`: time the main workflows on one nominal lab run (median of repeats)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from twin.apps.readme import SPEED_BLOCK, speed_table
from twin.base.jsonio import emit_json
from twin.cli._common import add_json_argument
from twin.cli._types import seed

HELP = "Benchmark replay, analytic floor, lab, identify, compensate, discrepancy and the force field."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `bench` options."""
    add_json_argument(parser, "the results")
    parser.add_argument(
        "--repeats", type=int, default=5, help="repeats per timed step, median reported (default 5)"
    )
    parser.add_argument(
        "--samples", type=int, help="only the first N commanded samples of the groove (quick smoke run)"
    )
    parser.add_argument("--seed", type=seed, default=0, help="seed of the lab run's noise (default 0)")
    parser.add_argument("--readme", type=Path, help="also write the speed table into FILE's generated block")


def run(args: argparse.Namespace) -> int:
    """Run the benchmarks."""
    from twin.apps.bench import format_table, run_benchmarks

    result = run_benchmarks(args.repeats, args.samples, seed=args.seed)
    out = sys.stderr if args.json == "-" else sys.stdout  # keep stdout pure JSON for `--json -`
    print(format_table(result), file=out)
    emit_json(args.json, result)
    if args.readme is not None:
        SPEED_BLOCK.update(args.readme, speed_table(result))
        print(f"speed table -> {args.readme}", file=out)
    return 0
