"""`tx200-twin place`: where to put the sheet for the least predicted error of a part (placement search,
`twin.apps.tasks.place`)."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

from twin.cli._common import (
    add_force_model_argument,
    add_ideal_argument,
    add_json_argument,
    add_process_arguments,
    add_robot_argument,
    add_scheduler_argument,
    finish,
    note,
    process_declaration,
)
from twin.cli._types import count, finite, seed

HELP = "Search the sheet's origin and yaw for the least predicted error of a part (screened, best confirmed by the twin)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `place` options."""
    add_ideal_argument(parser)
    parser.add_argument("--model", type=Path, help="twin model file (effects, K_q, process, placement)")
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    search = parser.add_argument_group("search (a box around the model's placement, else the cell's sheet origin)")
    search.add_argument("--candidates", type=count, default=512, help="candidate placements screened")
    search.add_argument("--confirm", type=count, default=5, help="best screened candidates simulated by the twin")
    search.add_argument("--seed", type=seed, default=0, help="seed of the candidates (a Latin hypercube)")
    search.add_argument("--box-mm", type=finite, nargs=3, metavar=("DX", "DY", "DZ"), default=[300.0, 400.0, 100.0],
                        help="half-widths of the origin's box along base x, y, z [mm]")
    search.add_argument("--yaw-range-deg", type=finite, default=180.0, help="half-range of the yaw [deg], <= 180")
    search.add_argument("--joint-margin-deg", type=finite, default=5.0,
                        help="smallest distance to a joint limit a feasible placement keeps [deg]")
    parser.add_argument("--workers", type=count, help="worker processes (default: every usable core)")
    add_scheduler_argument(parser)
    parser.add_argument("--figure", type=Path, metavar="PNG", help="write the map of the screened error to FILE")
    add_json_argument(parser, "the results")


def run(args: argparse.Namespace) -> int:
    """Run the search with a progress line on stderr; print the default and the best placement."""
    from twin.apps.tasks.place import PlaceRequest, place_task

    request = PlaceRequest(
        args.ideal, args.model, args.force_model, process_declaration(args), args.robot, args.candidates,
        args.confirm, args.seed, tuple(args.box_mm), args.yaw_range_deg, args.joint_margin_deg, args.workers,
        args.scheduler, args.figure, cell=getattr(args, "cell_record", None),
    )
    report = place_task(request, note, progress=_progress())
    return finish(args, report, protect=(args.ideal, args.model, args.process))


def _progress() -> Callable[[str, int, int], None]:
    """A progress line on stderr, rewritten in place: the stage, its jobs done and the seconds since now."""
    start = time.perf_counter()

    def progress(stage: str, done: int, total: int) -> None:
        print(f"\rplace: {stage} {done}/{total}, {time.perf_counter() - start:.1f} s", end="\n" if done == total else "",
              file=sys.stderr, flush=True)

    return progress
