"""`tx200-twin discrepancy`: find where twin and run disagree, name the missing effect, add it, show the shrink
(`twin.apps.tasks.discrepancy`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.cli._common import (
    add_force_model_argument,
    add_history_arguments,
    add_json_argument,
    add_process_arguments,
    add_robot_argument,
    finish,
    note,
    process_declaration,
)

HELP = (
    "Find where the twin and a measured run disagree, name the missing effect, add it, show the gap shrink."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `discrepancy` options."""
    parser.add_argument("run_dir", type=Path, help="a tx200-twin-run/1 directory (truth.json is never read)")
    parser.add_argument("--model", type=Path, help="start from this twin model file (effects, K_q, process)")
    add_history_arguments(parser)
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    parser.add_argument("--model-out", type=Path, help="write the augmented twin model file here")
    parser.add_argument(
        "--report", type=Path, help="write figures of the residual before/after into this folder"
    )
    parser.add_argument("--no-learn", action="store_true",
                        help="when no family explains the gap, do not learn the robot and the sheet from the run")
    parser.add_argument("--held-out", type=Path, metavar="RUN",
                        help="another run of the same cell, not learned from: the gap before -> after on it")
    add_json_argument(parser, "the findings")


def run(args: argparse.Namespace) -> int:
    """Run the workflow."""
    from twin.apps.tasks.discrepancy import DiscrepancyRequest, discrepancy_task
    from twin.apps.tasks.inputs import HistoryDeclaration

    history = HistoryDeclaration(args.history, args.symmetry, args.unchecked_symmetry)
    request = DiscrepancyRequest(args.run_dir, args.model, history, process_declaration(args), args.force_model,
                                 args.robot, args.model_out, args.report, not args.no_learn, args.held_out,
                                 cell=getattr(args, "cell_record", None))
    return finish(args, discrepancy_task(request, note),
                  protect=(args.run_dir, args.model, args.history, args.process, args.held_out))
