"""`tx200-twin learn`: a cell's twin (robot, sheet) from its nominal runs, as a model file (`twin.apps.tasks.learn`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.cli._common import add_json_argument, finish

HELP = "Learn the cell's robot (compliance, friction, servo) and sheet (forces, springback) from its nominal runs."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `learn` options (the tracker's: a `TrackerErrors` value, as a string: the parser loads no learner)."""
    parser.add_argument("runs", type=Path, nargs="+", metavar="RUN",
                        help="nominal runs of one cell (tracker and F/T streams), one robot at one placement; "
                        "with two or more, each is also replayed on a twin learned from the others")
    parser.add_argument("--model", type=Path, help="the declared twin (model file): the priors (default: the runs')")
    parser.add_argument("--write-model", type=Path, help="write the learned twin to FILE (a model file: --model's)")
    parser.add_argument("--dynamic", action="store_true", help="also learn the dynamic mode's servo from the first "
                        "run, for `replay --dynamic` (docs/dynamic-twin.md)")
    tracker = parser.add_mutually_exclusive_group()
    tracker.add_argument("--tracker-errors", dest="tracker", action="store_const", const="turned", default="offset",
                         help="also fit each run's tracker turned and late, carried as its clock (a robot's lag along "
                         "the path is then not compensated; docs/learning.md)")
    tracker.add_argument("--tracker-late", dest="tracker", action="store_const", const="late",
                         help="as --tracker-errors, its lateness alone")
    add_json_argument(parser, "what was learned and the gaps")


def run(args: argparse.Namespace) -> int:
    """Learn from the runs."""
    from twin.analysis.learn.tracker import TrackerErrors
    from twin.apps.tasks.learn import LearnRequest, learn_task

    report = learn_task(LearnRequest(tuple(args.runs), args.model, args.write_model, args.dynamic,
                                     TrackerErrors(args.tracker)))
    return finish(args, report, protect=(*args.runs, args.model))
