"""`tx200-twin path`: write the ideal groove path U_ID as CSV (thesis §1.2.3, Table 2.3)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from twin.base.csvio import emit_json
from twin.process.path import GrooveSpec, groove_path, write_path_csv

HELP = "Write the ideal zig-zag groove path (sheet frame) as CSV: t_s, x_mm, y_mm, z_mm, pass, direction."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the command's options."""
    d = GrooveSpec()
    parser.add_argument("--out", type=Path, required=True, help="output CSV file")
    parser.add_argument(
        "--passes", type=int, default=d.passes, help=f"number of passes N (default {d.passes})"
    )
    parser.add_argument(
        "--top-length-mm", type=float, default=d.top_length_m * 1e3, help="groove length L at the surface"
    )
    parser.add_argument(
        "--bottom-length-mm",
        type=float,
        default=d.bottom_length_m * 1e3,
        help="groove length B at full depth",
    )
    parser.add_argument("--depth-mm", type=float, default=d.depth_m * 1e3, help="final depth H")
    parser.add_argument("--feed-mm-s", type=float, default=d.feed_m_per_s * 1e3, help="constant feed [mm/s]")
    parser.add_argument(
        "--spacing-mm", type=float, default=d.spacing_m * 1e3, help="largest sample spacing [mm]"
    )
    parser.add_argument("--json", metavar="FILE", help="write the summary as JSON to FILE (- for stdout)")


def run(args: argparse.Namespace) -> int:
    """Build the path, write it and print a summary."""
    spec = GrooveSpec(
        top_length_m=args.top_length_mm / 1e3,
        bottom_length_m=args.bottom_length_mm / 1e3,
        depth_m=args.depth_mm / 1e3,
        passes=args.passes,
        feed_m_per_s=args.feed_mm_s / 1e3,
        spacing_m=args.spacing_mm / 1e3,
    )
    path = groove_path(spec)
    write_path_csv(path, args.out)
    payload = {
        "out": str(args.out),
        "samples": len(path),
        "passes": spec.passes,
        "length_mm": float(path.s_m[-1] * 1e3),
        "duration_s": float(path.t_s[-1]),
        "strokes_mm": [spec.stroke_m(k) * 1e3 for k in range(1, spec.passes + 1)],
        "rpp_mm": spec.rpp_m * 1e3,
        "final_depth_mm": float(-path.p_sheet_m[-1, 2] * 1e3),
        "wall_angle_deg": math.degrees(spec.wall_angle_rad),
    }
    emit_json(args.json, payload, protect=[args.out])
    out = sys.stderr if args.json == "-" else sys.stdout
    strokes = payload["strokes_mm"]
    assert isinstance(strokes, list)
    print(
        f"wrote {args.out}: {len(path)} samples, {spec.passes} passes, {path.s_m[-1] * 1e3:.2f} mm "
        f"in {path.t_s[-1]:.2f} s\n"
        f"strokes {strokes[0]:.2f} .. {strokes[-1]:.2f} mm (RpP {spec.rpp_m * 1e3:.3f} mm), "
        f"final depth {-path.p_sheet_m[-1, 2] * 1e3:.3f} mm, "
        f"wall angle {math.degrees(spec.wall_angle_rad):.2f} deg",
        file=out,
    )
    return 0
