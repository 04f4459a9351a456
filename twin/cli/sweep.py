"""`tx200-twin sweep`: Monte Carlo of the model's uncertainty -> distribution of the compensated residual
(`twin.apps.tasks.sweep`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from twin.cli._common import (
    add_history_arguments,
    add_ideal_argument,
    add_json_argument,
    add_process_arguments,
    add_robot_argument,
    add_scheduler_argument,
    finish,
    process_declaration,
)
from twin.cli._types import count, seed

HELP = "Monte Carlo of K_q / friction / sheet / force-scale uncertainty: distribution of the compensated residual."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `sweep` options."""
    parser.add_argument("--draws", type=count, default=200, help="parameter sets to replay (default 200; at most a "
                        "million, and what fits in half the machine's memory: twin.apps.sweep.check_draws)")
    parser.add_argument("--seed", type=seed, default=0, help="seed of the draws (default 0)")
    parser.add_argument("--workers", type=count, help="worker processes (default: every usable core)")
    add_scheduler_argument(parser)
    parser.add_argument(
        "--calibration", type=Path,
        help="calibration JSON with 'parameters' and 'sigma' (tx200-twin calibrate, e.g. docs/calibration.json); "
        "default: the model's values with the relative sigma of twin.apps.uncertainty.DEFAULT_RELATIVE_SIGMA",
    )
    parser.add_argument("--uncompensated", action="store_true", help="replay the ideal path, not its compensation")
    add_history_arguments(parser)
    add_ideal_argument(parser)
    parser.add_argument("--model", type=Path, help="twin model file (effects, K_q, process) of the nominal twin; "
                        "its force model must be the table field")
    add_process_arguments(parser)
    add_robot_argument(parser)
    parser.add_argument("--figure", type=Path, help="write the distribution figure (PNG) to FILE")
    add_json_argument(parser, "the results")


def run(args: argparse.Namespace) -> int:
    """Run the sweep with a progress bar on stderr."""
    from twin.apps.tasks.inputs import HistoryDeclaration
    from twin.apps.tasks.sweep import SweepRequest, sweep_task

    history = HistoryDeclaration(args.history, args.symmetry, args.unchecked_symmetry)
    request = SweepRequest(args.draws, args.seed, args.workers, args.scheduler, args.calibration,
                           args.uncompensated, history, args.ideal, args.figure, args.model, args.robot,
                           process_declaration(args), cell=getattr(args, "cell_record", None))
    report = sweep_task(request, note=_bar)
    return finish(args, report, protect=(args.calibration, args.history, args.ideal, args.model, args.process))


def _bar(text: str) -> None:
    """Write the progress bar's text as is (it redraws itself with a carriage return) to stderr."""
    print(text, end="", file=sys.stderr, flush=True)
