"""`tx200-twin export`: a path CSV as a robot program (VAL3, KRL, RAPID), G-code or a point list.

The robot is `--robot`, else the run's (`--run`), else the default; the format its own language unless `--format`
says otherwise (then a note); the tool length `--tool-length-mm`, else the run's `meta.json` `tool_length_m`, else
the robot's; the tool mass `--tool-mass-kg`, else the run's import record (`import.sensor.tool_mass_kg`), else the
robot model's tool body. The summary gives the process feed, the fastest programmed move in contact and warnings.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from twin.apps.export import FORMATS, LANGUAGES, export_path, robot_format
from twin.apps.export.motion import FEED_TOLERANCE, SAFE_MARGIN_MM
from twin.apps.export.parts import LIMITS
from twin.apps.export.program import default_cell
from twin.base.jsonio import emit_json
from twin.cli._common import (
    add_json_argument,
    add_placement_arguments,
    add_robot_argument,
    command_robot,
    placement_from,
)
from twin.errors import InputError
from twin.robot.description import load_robot
from twin.runs.format import Run, run_robot
from twin.runs.read import read_run

HELP = "Export a (compensated) path CSV as a robot program: Staubli VAL3, KUKA KRL, ABB RAPID, G-code or CSV."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `export` options."""
    parser.add_argument("path_csv", type=Path, help="path CSV t_s,x_mm,y_mm,z_mm (sheet frame)")
    parser.add_argument(
        "--format",
        choices=sorted(FORMATS),
        help="program format (default: the robot's own language: val3 for Staubli, krl for KUKA, rapid for ABB)",
    )
    parser.add_argument(
        "--out",
        type=Path,
        required=True,
        help="output: VAL3 application folder, KRL .src (its .dat beside it), RAPID .mod, G-code or CSV file",
    )
    add_robot_argument(parser)
    parser.add_argument(
        "--run",
        type=Path,
        metavar="RUN",
        help="a run (tx200-twin-run/1) the program is for: its robot and its meta.json tool_length_m",
    )
    parser.add_argument(
        "--tool-length-mm", type=float, metavar="MM",
        help="flange to tool tip along the flange z [mm] (default: the run's tool_length_m, else the robot's)",
    )
    parser.add_argument(
        "--tool-mass-kg", type=float, metavar="KG",
        help="tool mass for RAPID's tooldata [kg] (default: the run's imported sensor tool_mass_kg, else the "
        "robot model's tool body mass)",
    )
    parser.add_argument(
        "--safe-height-mm", type=float, metavar="MM",
        help="approach and retract height, sheet frame z [mm]: the program moves (joint move) above the first point, "
        f"down onto the path and back up at the end (default: the sheet top z = 0 or the path's highest point, "
        f"whichever is higher, + {SAFE_MARGIN_MM:g} mm)",
    )
    parser.add_argument(
        "--feed-mm-s", type=float, metavar="MM_S",
        help=f"the process feed [mm/s]; a path move faster than {FEED_TOLERANCE:g}x it is programmed at it "
        "(default: the median of the path's feeds)",
    )
    parser.add_argument(
        "--max-points", type=int, default=0, metavar="N",
        help=f"points per file before a KRL or RAPID program is split into parts and a main (default: KRL "
        f"{LIMITS['krl']}, RAPID {LIMITS['rapid']}, as RoboDK's posts)",
    )
    add_placement_arguments(parser, "sheet placement (the program's sheet frame)")
    add_json_argument(parser, "a summary")


def _run_tool_mass_kg(recorded: Run | None) -> float | None:
    """The tool mass an imported run records (`import.sensor.tool_mass_kg`, the mass below the F/T sensor), if > 0."""
    if recorded is None:
        return None
    mass = recorded.meta.get("import", {}).get("sensor", {}).get("tool_mass_kg")
    return float(mass) if isinstance(mass, int | float) and mass > 0 else None


def run(args: argparse.Namespace) -> int:
    """Export and print a summary."""
    recorded = read_run(args.run, require_forces=False) if args.run is not None else None
    if recorded is not None and args.robot is not None:
        given, made = load_robot(args.robot), run_robot(recorded.meta, Path(args.run) / "meta.json")
        if given.source != made.source:
            raise InputError(
                f"--robot gives robot {given.name!r}, but the run {args.run} was made with {made.name!r} (its "
                "tool_length_m is that robot's tool); expected the same robot, or leave out --robot or --run"
            )
    robot = command_robot(args, None, recorded)
    fmt = args.format or robot_format(robot)
    if fmt in LANGUAGES and LANGUAGES[fmt] != robot.language:
        print(
            f"note: writing {LANGUAGES[fmt]} for robot {robot.name} ({robot.vendor} {robot.model}), whose "
            f"{robot.controller} runs {robot.language}: the program's configuration is {robot.name}'s IK solution",
            file=sys.stderr,
        )
    for option, value in (("--tool-length-mm", args.tool_length_mm), ("--tool-mass-kg", args.tool_mass_kg),
                          ("--feed-mm-s", args.feed_mm_s)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InputError(f"{option} {value:g}: expected a finite number > 0")
    mass = args.tool_mass_kg if args.tool_mass_kg is not None else _run_tool_mass_kg(recorded)
    cell = default_cell(mass, placement_from(args), robot)
    if args.tool_length_mm is not None:
        cell = replace(cell, tool_length_mm=args.tool_length_mm)
    elif recorded is not None:
        cell = replace(cell, tool_length_mm=1e3 * float(recorded.meta["tool_length_m"]))
    path, files, feeds = export_path(
        args.path_csv, fmt, args.out, cell=cell, safe_z_mm=args.safe_height_mm, process_feed_mm_s=args.feed_mm_s,
        max_points=args.max_points,
    )
    feed = path.feed_mm_s
    config = path.cell.configuration
    warnings = feeds.warnings()
    language = LANGUAGES.get(fmt, "")
    payload = {
        "format": fmt,
        "robot": path.cell.robot,
        "program": path.name,
        "points": len(path.points_mm),
        "files": [str(f) for f in files],
        "feed_mm_s": {
            "process": feeds.process_mm_s,
            "max_in_contact": feeds.max_in_contact_mm_s,
            "path_max_in_contact": feeds.path_max_in_contact_mm_s,
            "slowed_moves": feeds.slowed,
            "added_time_s": feeds.added_time_s,
            "min": float(np.min(feed)),
            "median": float(np.median(feed)),
            "max": float(np.max(feed)),
        },
        "safe_height_mm": feeds.safe_z_mm,
        "warnings": warnings,
        "sheet_origin_in_base_mm": path.cell.p_base_sheet_mm.tolist(),
        "tool_length_mm": path.cell.tool_length_mm,
        "tool_mass_kg": path.cell.tool_mass_kg,
        "configuration": None if config is None else {
            "program": config.text(language),
            "description": config.describe(),
            "axes_deg": list(config.axes_deg),
        },
    }
    out = sys.stderr if args.json == "-" else sys.stdout
    configured = "" if config is None else f", configuration {config.text(language)}"
    print(
        f"export {args.path_csv} -> {fmt} program {path.name} for {robot.name}: {len(path.points_mm)} points "
        f"(approach and retract at z = {feeds.safe_z_mm:.2f} mm), process feed {feeds.process_mm_s:.2f} mm/s, "
        f"max feed in contact {feeds.max_in_contact_mm_s:.2f} mm/s (path {feeds.path_max_in_contact_mm_s:.2f}), "
        f"tool {path.cell.tool_length_mm:.2f} mm {path.cell.tool_mass_kg:.3g} kg{configured}; "
        f"wrote {', '.join(str(f) for f in files)}",
        file=out,
    )
    for warning in warnings:
        print(f"warning: {warning}", file=sys.stderr)
    emit_json(args.json, payload, protect=[args.path_csv])
    return 0
