"""`tx200-twin path`: write an ideal tool path U_ID as CSV, checked for reach (`twin.apps.tasks.path`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.cli._common import (
    add_json_argument,
    add_placement_arguments,
    add_process_arguments,
    add_robot_argument,
    finish,
    note,
    placement_from,
    process_declaration,
)
from twin.cli._types import count, feed_mm_s, finite, length_mm
from twin.process.toolpath.groove import GrooveSpec
from twin.process.toolpath.shapes import MODES, SHAPES, PartSpec

HELP = (
    "Write an ideal tool path (sheet frame) as CSV t_s, x_mm, y_mm, z_mm, pass, direction: the groove, a cone, "
    "pyramid, variable-wall-angle cone, or an imported G-code program; checks reach along the whole path."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the command's options."""
    d = GrooveSpec()
    parser.add_argument("--out", type=Path, required=True, help="output CSV file")
    parser.add_argument("--shape", choices=("groove", *SHAPES), default="groove", help="part (default groove)")
    parser.add_argument("--gcode", type=Path, metavar="FILE", help="import this G-code program instead of --shape")
    parser.add_argument("--gcode-out", type=Path, metavar="FILE", help="also write the path as G-code (G1, mm)")
    parser.add_argument(
        "--stl-out", type=Path, metavar="FILE",
        help="also write the target part as a binary STL [mm]: the surface a rigid machine forms along the path "
        "(height-map ISF model, after elastic recovery), for `check --target-stl`",
    )
    parser.add_argument(
        "--design-stl", type=Path, metavar="FILE",
        help="also write the design part as a binary STL [mm]: the sheet's tool-side surface a rigid machine forms "
        "with no springback (the tool sphere's envelope, the bottom lowered), for `check --target-stl --scan`",
    )
    parser.add_argument("--depth-mm", type=length_mm, help="final depth H (default: groove 10, other parts 40)")
    parser.add_argument("--feed-mm-s", type=feed_mm_s, default=d.feed_m_per_s * 1e3, help="constant feed [mm/s]")
    parser.add_argument("--spacing-mm", type=length_mm, default=d.spacing_m * 1e3,
                        help="largest sample spacing (G-code: the chords of arcs and the pieces of lines)")
    _add_shape_arguments(parser)
    add_process_arguments(parser)
    place = add_placement_arguments(parser, "placement and reach check")
    add_robot_argument(place)
    place.add_argument("--no-reach-check", action="store_true", help="skip the IK check along the path")
    add_json_argument(parser, "the summary")


def _add_shape_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the groove's and the parts' (cone, pyramid, vwa-cone) geometry options."""
    d, p = GrooveSpec(), PartSpec()
    groove = parser.add_argument_group("groove")
    groove.add_argument("--passes", type=count, default=d.passes, help=f"number of passes N (default {d.passes})")
    groove.add_argument("--top-length-mm", type=length_mm, default=d.top_length_m * 1e3,
                        help="groove length L at the surface")
    groove.add_argument("--bottom-length-mm", type=length_mm, default=d.bottom_length_m * 1e3,
                        help="groove length B at full depth")
    part = parser.add_argument_group("cone, pyramid, vwa-cone")
    part.add_argument("--mode", choices=MODES, default=p.mode, help="descent (default spiral)")
    part.add_argument("--top-width-mm", type=length_mm, default=2e3 * p.top_half_width_m,
                      help="tool-tip contour at the surface: cone diameter or pyramid side (default 120)")
    part.add_argument("--wall-angle-deg", type=finite, default=p.wall_angle_deg, help="wall angle (vwa-cone: top)")
    part.add_argument("--wall-angle-end-deg", type=finite, default=p.wall_angle_end_deg,
                      help="vwa-cone: wall angle at the bottom")
    part.add_argument("--step-down-mm", type=length_mm, default=p.step_down_m * 1e3, help="largest step-down")


def run(args: argparse.Namespace) -> int:
    """Build or import the path, check its reach, write it and print a summary."""
    from twin.apps.tasks.path import PathRequest, path_task

    request = PathRequest(
        args.out, args.shape, args.gcode, args.gcode_out, args.stl_out, args.design_stl, args.depth_mm,
        args.feed_mm_s, args.spacing_mm, args.passes, args.top_length_mm, args.bottom_length_mm, args.mode,
        args.top_width_mm, args.wall_angle_deg, args.wall_angle_end_deg, args.step_down_mm,
        process_declaration(args), placement_from(args), args.robot, not args.no_reach_check,
        getattr(args, "cell_record", None),
    )
    return finish(args, path_task(request, note), protect=(args.out,))
