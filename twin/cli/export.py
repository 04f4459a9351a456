"""`tx200-twin export`: a path CSV as a robot program (VAL3, KRL, RAPID), G-code or a point list.

The robot is `--robot`, else the run's (`--run`), else the default; the format its own language unless `--format`
says otherwise (then a note); the tool length the run's `meta.json` `tool_length_m`, else the robot's.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from twin.apps.export import FORMATS, LANGUAGES, export_path, robot_format
from twin.apps.export.program import default_cell
from twin.base.csvio import emit_json
from twin.cli._common import add_placement_arguments, add_robot_argument, command_robot, placement_from
from twin.errors import InputError
from twin.robot.description import load_robot
from twin.runs.format import run_robot
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
        metavar="RUN_DIR",
        help="a run (tx200-twin-run/1) the program is for: its robot and its meta.json tool_length_m",
    )
    parser.add_argument(
        "--tool-mass-kg", type=float, default=1.0, help="tool mass for RAPID's tooldata (default 1.0)"
    )
    add_placement_arguments(parser, "sheet placement (the program's sheet frame)")
    parser.add_argument("--json", metavar="FILE", help="write a summary as JSON to FILE (- for stdout)")


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
    cell = default_cell(args.tool_mass_kg, placement_from(args), robot)
    if recorded is not None:
        cell = replace(cell, tool_length_mm=1e3 * float(recorded.meta["tool_length_m"]))
    path, files = export_path(args.path_csv, fmt, args.out, cell=cell)
    feed = path.feed_mm_s
    config = path.cell.configuration
    language = LANGUAGES.get(fmt, "")
    payload = {
        "format": fmt,
        "robot": path.cell.robot,
        "program": path.name,
        "points": len(path.points_mm),
        "files": [str(f) for f in files],
        "feed_mm_s": {
            "min": float(np.min(feed)),
            "median": float(np.median(feed)),
            "max": float(np.max(feed)),
        },
        "sheet_origin_in_base_mm": path.cell.p_base_sheet_mm.tolist(),
        "tool_length_mm": path.cell.tool_length_mm,
        "configuration": None if config is None else {
            "program": config.text(language),
            "description": config.describe(),
            "axes_deg": list(config.axes_deg),
        },
    }
    out = sys.stderr if args.json == "-" else sys.stdout
    configured = "" if config is None else f", configuration {config.text(language)}"
    print(
        f"export {args.path_csv} -> {fmt} program {path.name} for {robot.name}: {len(path.points_mm)} points, "
        f"feed {np.median(feed):.2f} mm/s (median), tool {path.cell.tool_length_mm:.2f} mm{configured}; "
        f"wrote {', '.join(str(f) for f in files)}",
        file=out,
    )
    emit_json(args.json, payload, protect=[args.path_csv])
    return 0
