"""`tx200-twin export`: a path CSV as a robot program (VAL3, KRL, RAPID), G-code or a point list."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from twin.apps.export import FORMATS, export_path
from twin.apps.export.program import default_cell
from twin.base.csvio import emit_json
from twin.cli._common import add_placement_arguments, placement_from

HELP = "Export a (compensated) path CSV as a robot program: Staubli VAL3, KUKA KRL, ABB RAPID, G-code or CSV."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `export` options."""
    parser.add_argument("path_csv", type=Path, help="path CSV t_s,x_mm,y_mm,z_mm (sheet frame)")
    parser.add_argument("--format", required=True, choices=sorted(FORMATS), help="program format")
    parser.add_argument(
        "--out",
        type=Path,
        required=True,
        help="output: VAL3 application folder, KRL .src (its .dat beside it), RAPID .mod, G-code or CSV file",
    )
    parser.add_argument(
        "--tool-mass-kg", type=float, default=1.0, help="tool mass for RAPID's tooldata (default 1.0)"
    )
    add_placement_arguments(parser, "sheet placement (the program's sheet frame)")
    parser.add_argument("--json", metavar="FILE", help="write a summary as JSON to FILE (- for stdout)")


def run(args: argparse.Namespace) -> int:
    """Export and print a summary."""
    path, files = export_path(args.path_csv, args.format, args.out, cell=default_cell(args.tool_mass_kg, placement_from(args)))
    feed = path.feed_mm_s
    payload = {
        "format": args.format,
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
    }
    out = sys.stderr if args.json == "-" else sys.stdout
    print(
        f"export {args.path_csv} -> {args.format} program {path.name}: {len(path.points_mm)} points, "
        f"feed {np.median(feed):.2f} mm/s (median); wrote {', '.join(str(f) for f in files)}",
        file=out,
    )
    emit_json(args.json, payload, protect=[args.path_csv])
    return 0
