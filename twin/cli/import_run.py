"""`tx200-twin import`: assemble a `tx200-twin-run/1` directory from a cell's raw exports and a TOML mapping."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from twin.base.jsonio import emit_json
from twin.cli._common import (
    add_json_argument,
    add_placement_arguments,
    add_robot_argument,
    given,
    process_declaration,
)
from twin.robot.description import DEFAULT_ROBOT
from twin.runs.importer import import_to_directory

HELP = "Import raw cell exports (tracker, force sensor, robot path) described by a TOML mapping into a run."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `import` options."""
    parser.add_argument(
        "--mapping", type=Path, required=True, help="TOML mapping of the raw exports (docs/import-export.md)"
    )
    parser.add_argument("--out", type=Path, required=True, help="run directory to write")
    parser.add_argument(
        "--overwrite", action="store_true", help="replace an existing non-empty run directory"
    )
    add_robot_argument(parser)
    add_placement_arguments(parser, "sheet placement (recorded in the run; default: the mapping's [run] origin_mm, "
                            "yaw_deg, else the cell's, else the robot's)")
    add_json_argument(parser, "the import report")


def run(args: argparse.Namespace) -> int:
    """Import the run and print what was done."""
    result = import_to_directory(args.mapping, args.out, overwrite=args.overwrite, robot=given(args, "robot"),
                                 origin_mm=given(args, "origin_mm"), yaw_deg=given(args, "yaw_deg"),
                                 cell=getattr(args, "cell_record", None), process=process_declaration(args))
    report = result.report
    out = sys.stderr if args.json == "-" else sys.stdout
    reg = report["registration"]
    how = f"{reg['points']} reference points" if reg["points"] else "the given T_sheet_tracker"
    counts = ", ".join(f"{n} {name}" for name, n in report["samples"].items())
    print(f"import {args.mapping} -> {args.out}: {counts} samples", file=out)
    meta = result.run.meta
    place = meta.get("placement") or {}
    origin = place.get("origin_base_mm")
    print(f"robot {meta.get('robot', f'{DEFAULT_ROBOT} (the default; --robot or run.robot names yours)')}, sheet origin "
          + ("the robot's default" if origin is None else "(" + ", ".join(f"{v:g}" for v in origin) + ") mm")
          + f", yaw {place.get('yaw_deg', 0.0):g} deg, tool {1e3 * meta['tool_length_m']:g} mm", file=out)
    print(
        f"tracker frame from {how}: fit residual rms {reg['residual_rms_mm']:.4f} mm "
        f"(max {reg['residual_max_mm']:.4f} mm)",
        file=out,
    )
    for name, clock in report["clocks"].items():
        extra = f", refined on the {clock['refined_on']}" if clock["refined_on"] else ""
        print(
            f"{name} clock: offset {clock['offset_s']:.6f} s ± {clock['sigma_s'] * 1e3:.3f} ms "
            f"({clock['method']}{extra})",
            file=out,
        )
    emit_json(args.json, {"out": args.out, **report}, protect=[args.mapping])
    return 0
