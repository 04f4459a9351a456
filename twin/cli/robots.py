"""`tx200-twin robots`: the shipped robots (and a description file of your own), with the source of every number
(`twin.apps.tasks.robots`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.apps.tasks.robots import TASK_POINT_MM  # light: MuJoCo loads only when the task runs
from twin.cli._common import add_json_argument, finish
from twin.cli._types import finite

HELP = "List the robots: name, vendor, language, reach, payload, tool, joint stiffness and where each number comes from."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `robots` options."""
    parser.add_argument("--file", type=Path, metavar="ROBOT.toml", help="also list a robot description of your own")
    parser.add_argument(
        "--task-point-mm", type=finite, nargs=3, default=TASK_POINT_MM, metavar=("X", "Y", "Z"),
        help="the common task point, tool down, where each robot's Cartesian compliance is compared [mm, base "
        f"frame] (default {' '.join(f'{v:g}' for v in TASK_POINT_MM)})",
    )
    parser.add_argument("--markdown", type=Path, help="write the comparison page (docs/robots.md) to FILE")
    add_json_argument(parser, "the robots")


def run(args: argparse.Namespace) -> int:
    """List the robots."""
    from twin.apps.tasks.robots import RobotsRequest, robots_task

    report = robots_task(RobotsRequest(args.file, tuple(args.task_point_mm), args.markdown))
    return finish(args, report, protect=(args.file,))
