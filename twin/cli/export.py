"""`tx200-twin export`: a path CSV as a robot program (VAL3, KRL, RAPID), G-code or a point list
(`twin.apps.tasks.export`: which robot, format, tool length and tool mass win)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.apps.export import FORMATS
from twin.apps.export.motion import FEED_TOLERANCE, SAFE_MARGIN_MM
from twin.apps.export.parts import LIMITS
from twin.cli._common import (
    add_json_argument,
    add_placement_arguments,
    add_robot_argument,
    finish,
    given,
    note,
)
from twin.robot.controller import BASE_NUMBERS, DEFAULT_BASE_NUMBER, DEFAULT_TOOL_NUMBER, TOOL_NUMBERS
from twin.sim.online_settings import MAX_CORRECTION_HELP

HELP = "Export a (compensated) path CSV as a robot program: Staubli VAL3, KUKA KRL, ABB RAPID, G-code or CSV."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `export` options."""
    parser.add_argument("path_csv", type=Path, help="path CSV t_s,x_mm,y_mm,z_mm (sheet frame)")
    parser.add_argument("--format", choices=sorted(FORMATS), help="program format (default: the robot's own "
                        "language: val3 for Staubli, krl for KUKA, rapid for ABB)")
    parser.add_argument("--out", type=Path, required=True, help="output: VAL3 application folder, KRL .src (its .dat "
                        "beside it), RAPID .mod, G-code or CSV file")
    add_robot_argument(parser)
    parser.add_argument("--run", type=Path, metavar="RUN",
                        help="a run (tx200-twin-run/1) the program is for: its robot, its sheet placement and its tool "
                        "(meta.json), unless a flag gives them (a flag > the run > --cell > the robot's defaults)")
    _add_program_arguments(parser)
    add_placement_arguments(parser, "sheet placement (the program's sheet frame)")
    parser.add_argument("--online", action="store_true", help="the program with the twin's online correction on "
                        "(KUKA: KRL with RSI and its Ethernet configuration; ABB: RAPID with EGM, --egm-mode, and "
                        "its configuration; Stäubli: VAL3 alter moves; for `tx200-twin online --serve`)")
    parser.add_argument("--egm-mode", choices=("pose", "path"), help="ABB: EGM position guidance (default; every "
                        "axis, 4 ms) or path correction (y, z of the path frame, 48 ms: drops the along-path part)")
    add_json_argument(parser, "a summary")


def _add_program_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the tool, approach, feed and file-size options of the program."""
    parser.add_argument("--tool-length-mm", type=float, metavar="MM", help="flange to tool tip along the flange z "
                        "[mm] (default: the run's tool_length_m, else the robot's)")
    parser.add_argument("--tool-mass-kg", type=float, metavar="KG", help="tool mass for the program's load data "
                        "(RAPID tooldata, KRL LOAD_DATA) [kg] (default: the run's imported sensor tool_mass_kg, else the "
                        "robot model's tool body mass)")
    parser.add_argument("--safe-height-mm", type=float, metavar="MM", help="approach and retract height, sheet frame "
                        "z [mm]: the program moves (joint move) above the first point, down onto the path and back up "
                        "at the end (default: the sheet top z = 0 or the path's highest point, whichever is higher, "
                        f"+ {SAFE_MARGIN_MM:g} mm)")
    parser.add_argument("--feed-mm-s", type=float, metavar="MM_S", help=f"the process feed [mm/s]; a path move "
                        f"faster than {FEED_TOLERANCE:g}x it is programmed at it (default: the median of the path's "
                        "feeds)")
    parser.add_argument("--max-points", type=int, default=0, metavar="N", help="points per file before a KRL or "
                        f"RAPID program is split into parts and a main (default: KRL {LIMITS['krl']}, RAPID "
                        f"{LIMITS['rapid']}, as RoboDK's posts)")
    parser.add_argument("--tool-number", type=int, metavar="N", help="KRL: the controller's tool and load slot the "
                        f"program overwrites and uses, TOOL_DATA[N] and LOAD_DATA[N], {TOOL_NUMBERS.start}.."
                        f"{TOOL_NUMBERS.stop - 1} (default: a --cell's controller.tool_number, else "
                        f"{DEFAULT_TOOL_NUMBER}; the cell's calibrated tool 1 is never written unless asked)")
    parser.add_argument("--base-number", type=int, metavar="N", help="KRL: the controller's base slot the program "
                        f"overwrites and uses with the sheet frame, BASE_DATA[N], {BASE_NUMBERS.start}.."
                        f"{BASE_NUMBERS.stop - 1} (default: a --cell's controller.base_number, else "
                        f"{DEFAULT_BASE_NUMBER})")
    parser.add_argument("--max-correction-mm", type=float, metavar="MM", help=MAX_CORRECTION_HELP)


def run(args: argparse.Namespace) -> int:
    """Export and print a summary."""
    from twin.apps.tasks.export import ExportRequest, export_task

    origin = given(args, "origin_mm")
    request = ExportRequest(
        args.path_csv, args.out, args.format, given(args, "robot"), args.run, given(args, "tool_length_mm"),
        given(args, "tool_mass_kg"), args.safe_height_mm, args.feed_mm_s, args.max_points, args.online,
        getattr(args, "cell_record", None), None if origin is None else tuple(origin), given(args, "yaw_deg"),
        args.tool_number, args.base_number, egm_mode=args.egm_mode, max_correction_mm=args.max_correction_mm,
    )
    return finish(args, export_task(request, note), protect=(args.path_csv, args.run))
