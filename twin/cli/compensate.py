"""`tx200-twin compensate`: offline compensation of the groove path (formula Eq. 4.28, or with the twin)
(`twin.apps.tasks.compensate`, with `--target-stl` `twin.apps.tasks.compensate_part`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.analysis.compensate import TWIN_MAX_ITER, TWIN_TOL_M
from twin.cli._common import (
    add_force_model_argument,
    add_history_arguments,
    add_ideal_argument,
    add_json_argument,
    add_placement_arguments,
    add_process_arguments,
    add_robot_argument,
    finish,
    note,
    placement_given,
    process_declaration,
)
from twin.cli._types import count, finite

HELP = "Compensate the ideal path offline (Eq. 4.28 formula, or iterating the twin) and write the command."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `compensate` options."""
    parser.add_argument("--method", required=True, choices=("formula", "twin"))
    parser.add_argument("--stiffness", type=Path, help="JSON with k_r_n_per_mm (2x2 x-z or 3x3); formula only")
    parser.add_argument("--model", type=Path, help="twin model file (effects, K_q, process) for --method twin")
    add_history_arguments(parser)
    add_ideal_argument(parser)
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    add_placement_arguments(parser, "sheet placement (the twin's)")
    parser.add_argument("--tol-mm", type=finite, default=1e3 * TWIN_TOL_M,
                        help="--method twin: stop when the rms residual is within this [mm]")
    parser.add_argument("--max-iter", type=count, default=TWIN_MAX_ITER, help="--method twin: iteration limit")
    parser.add_argument("--dynamic", action="store_true", help="--method twin: then iterate the command on the dynamic "
                        "twin, under the servo the model learned (`learn --dynamic`; docs/dynamic-twin.md)")
    parser.add_argument("--forces-from", type=Path, metavar="RUN", help="--method twin: the next part from the "
                        "last one's run of --ideal: the ideal less the twin's deflection under the run's forces")
    _add_part_arguments(parser)
    parser.add_argument("--out", type=Path, required=True, help="compensated path, commanded.csv format")
    add_json_argument(parser, "the numbers")


def _add_part_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the part's options (`--target-stl`, learning from the last part's scan, its figure and recording)."""
    part = parser.add_argument_group("the formed part to the design (--method twin, a height-map force model)")
    part.add_argument("--target-stl", type=Path, metavar="DESIGN",
                      help="design surface (STL, PLY or OBJ; sheet frame, mm, tool side, z = 0 at the sheet's top): "
                      "compensate so that the twin's part after unclamping lies on it, springback included")
    part.add_argument("--part-iterations", type=count, default=2, help="outer iterations on the part (default 2)")
    part.add_argument("--learn-from", type=Path, metavar="RUN", help="the last part's run (its command, part "
                      "scan and tool radius): the next command learned from its scan (--learn-at)")
    part.add_argument("--learn-at", choices=("twin", "formed", "tip"), default="twin",
                      help="how the scan's error is learned: twin, the part's miss of the twin's (needs --ideal); "
                      "formed, the error of the surface each sample formed; tip, under its tip (default twin)")
    part.add_argument("--learn-gain", type=finite, default=1.0, help="learning gain (0, 1] (default 1)")
    part.add_argument("--learn-smoothing-mm", type=finite, default=2.0, help="Gaussian smoothing of the learned "
                      "error, along the path (tip, formed) or over x-y (twin), > 0 (default 2)")
    part.add_argument("--figure", type=Path, metavar="PNG", help="deviation maps from the design: the twin's "
                      "predicted part at each iteration (with --learn-from: the last part's scan)")
    part.add_argument("--rrd", type=Path, metavar="RRD",
                      help="rerun recording: the design, and each iteration's surface coloured by its deviation")


def run(args: argparse.Namespace) -> int:
    """Compensate."""
    from twin.apps.tasks.compensate import CompensateRequest, compensate_task

    if args.forces_from is not None:  # the next part from the last one's forces (`twin.apps.tasks.compensate_next`)
        from twin.apps.tasks.compensate_next import next_part_request, next_part_task

        following = next_part_request(vars(args))
        return finish(args, next_part_task(following, note), protect=following.inputs())
    from twin.apps.tasks.inputs import HistoryDeclaration

    history = (HistoryDeclaration(args.history, args.symmetry, args.unchecked_symmetry) if args.target_stl is None
               else HistoryDeclaration())  # the part (--target-stl) ignores the FE history
    request = CompensateRequest(
        args.method, args.out, stiffness=args.stiffness, model=args.model, history=history, ideal=args.ideal,
        force_model=args.force_model, declaration=process_declaration(args), robot=args.robot,
        placement=placement_given(args), tol_mm=args.tol_mm, max_iter=args.max_iter,
        target_stl=args.target_stl, part_iterations=args.part_iterations, learn_from=args.learn_from,
        learn_at=args.learn_at, learn_gain=args.learn_gain, learn_smoothing_mm=args.learn_smoothing_mm,
        figure=args.figure, rrd=args.rrd, cell=getattr(args, "cell_record", None), dynamic=args.dynamic,
    )
    return finish(args, compensate_task(request, note), protect=(
        args.stiffness, args.model, args.history, args.ideal, args.process, args.target_stl, args.learn_from))
