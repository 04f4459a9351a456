"""`tx200-twin replay`: simulate a run's commanded path on the twin and compare with its measurements
(`twin.apps.tasks.replay`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.cli._common import (
    add_force_model_argument,
    add_json_argument,
    add_process_arguments,
    add_robot_argument,
    finish,
    note,
    process_declaration,
)

HELP = "Replay a measured run on the twin and report the gap (position and force)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `replay` options."""
    parser.add_argument("run_dir", type=Path, help="a tx200-twin-run/1 directory")
    parser.add_argument(
        "--model", type=Path, help="twin model file (effects, K_q, process) from `discrepancy --model-out`"
    )
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    parser.add_argument("--forces", choices=("twin", "measured"), default="twin",
                        help="measured: also drive the twin's robot by the run's F/T stream and split the gap into "
                        "the robot's part and the sheet's part")
    parser.add_argument("--dynamic", action="store_true", help="step the arm in time, its servo fitted on this run "
                        "(docs/dynamic-twin.md; about 80 dynamic replays)")
    add_json_argument(parser, "the metrics")
    parser.add_argument("--rrd", type=Path, help="also save a rerun recording of the replay to FILE")
    parser.add_argument("--figure", type=Path, metavar="PNG", help="also write a figure of the replay: measured vs "
                        "simulated tool tip minus the command, on x, y and z [mm] against time [s]")


def run(args: argparse.Namespace) -> int:
    """Replay the run."""
    from twin.apps.tasks.replay import ReplayRequest, replay_task

    request = ReplayRequest(args.run_dir, args.model, process_declaration(args), args.force_model, args.robot,
                            args.forces, args.rrd, args.figure, getattr(args, "cell_record", None), args.dynamic)
    return finish(args, replay_task(request, note), protect=(args.run_dir, args.model, args.process))
