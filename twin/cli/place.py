"""`tx200-twin place`: where to put the sheet for the least predicted error of a part (placement search)."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from twin.base.jsonio import emit_json
from twin.cli._common import (
    add_force_model_argument,
    add_ideal_argument,
    add_json_argument,
    add_process_arguments,
    add_robot_argument,
    add_scheduler_argument,
    ideal_from_arguments,
    spec_from_arguments,
)
from twin.cli._types import count, finite, seed
from twin.errors import InputError

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
    from twin.analysis.placement_search import SearchBox, describe, search_placement

    ideal = ideal_from_arguments(args)
    spec = spec_from_arguments(args, ideal.p_sheet_m)
    if any(v < 0 for v in args.box_mm) or not 0.0 <= args.yaw_range_deg <= 180.0 or args.joint_margin_deg < 0:
        raise InputError(f"--box-mm {' '.join(f'{v:g}' for v in args.box_mm)} --yaw-range-deg "
                         f"{args.yaw_range_deg:g} --joint-margin-deg {args.joint_margin_deg:g}: expected half-widths "
                         ">= 0 mm, a yaw half-range in [0, 180] deg and a margin >= 0 deg")
    if args.confirm > args.candidates:
        raise InputError(f"--confirm {args.confirm} > --candidates {args.candidates}: expected at most the candidates")
    box = SearchBox(half_width_m=(args.box_mm[0] / 1e3, args.box_mm[1] / 1e3, args.box_mm[2] / 1e3),
                    half_yaw_rad=math.radians(args.yaw_range_deg))
    start = time.perf_counter()

    def progress(stage: str, done: int, total: int) -> None:
        print(f"\rplace: {stage} {done}/{total}, {time.perf_counter() - start:.1f} s", end="\n" if done == total else "",
              file=sys.stderr, flush=True)

    result = search_placement(
        ideal, spec, candidates=args.candidates, confirm=args.confirm, seed=args.seed, box=box,
        joint_margin_rad=math.radians(args.joint_margin_deg), workers=args.workers, scheduler=args.scheduler,
        progress=progress,
    )
    summary = result.summary()
    if args.figure is not None:
        from twin.viz.placement_figure import placement_figure

        summary["figure"] = str(placement_figure(result, args.figure))
    out = sys.stderr if args.json == "-" else sys.stdout
    d, skipped = summary["default"], ", ".join(f"{k} {v}" for k, v in summary["infeasible"].items() if v)
    print(f"place: {summary['feasible']} of {summary['candidates']} candidates feasible"
          f"{f' (skipped: {skipped})' if skipped else ''}, on {summary['where']} in {result.timings_s['total']:.1f} s",
          file=out)
    print(f"  default  {describe(result.default_row)}: simulated rms {_mm(d['simulated_rms_mm'])}, "
          f"max {_mm(d['simulated_max_mm'])} (screened rms {_mm(d['screened_rms_mm'])}, "
          f"{d['screened_status']})", file=out)
    best = result.best
    if best is None:
        print("  no confirmed candidate is feasible along the whole path", file=out)
    else:
        b = summary["best"]
        print(f"  best     {describe(result.rows[best])}: simulated rms {_mm(b['simulated_rms_mm'])}, "
              f"max {_mm(b['simulated_max_mm'])} (screened rms {_mm(b['screened_rms_mm'])}), "
              f"{summary['best_over_default_rms']:.2f}x the default's rms", file=out)
    protect = [p for p in (args.ideal, args.model, args.process) if p is not None]
    emit_json(args.json, summary, protect=protect)
    return 0


def _mm(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.3f} mm"
