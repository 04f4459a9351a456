"""`tx200-twin identify`: fit the robot's Cartesian stiffness K_R (thesis §4.2), the joint stiffness K_q, or the
sheet's forces or springback (`twin.apps.tasks.identify`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.cli._common import (
    add_force_model_argument,
    add_json_argument,
    add_process_arguments,
    add_robot_argument,
    finish,
    note,
    process_declaration,
)

HELP = ("Identify K_R (Method 1: load cases; Method 2: a run), the joint stiffness K_q, the sheet's forces, or the "
        "part's springback.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the command's options."""
    parser.add_argument("--method", type=int, choices=(1, 2), default=1,
                        help="1: static load cases (--loads); 2: a nominal run directory (RUN_DIR)")
    parser.add_argument("--loads", type=Path,
                        help="Method 1 load cases CSV: fx_n, fy_n, fz_n, dx_mm, dy_mm, dz_mm (one row per case)")
    parser.add_argument("run_dir", nargs="?", type=Path, help="Method 2: run directory (tx200-twin-run/1)")
    _add_sheet_arguments(parser)
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    add_json_argument(parser, "the result")
    parser.add_argument("--write-model", type=Path, metavar="FILE",
                        help="put the identified K_q into the twin: FILE.json (twin model file) or FILE.xml (MJCF)")


def _add_sheet_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--forces RUN`, `--springback RUN --design DESIGN` and `--model` (the sheet's fits)."""
    parser.add_argument(
        "--forces", type=Path, metavar="RUN",
        help="fit the sheet force model's level and shape to this run's measured forces (the process its meta.json "
        "records, or --process/--material ...); --write-model puts the fit into a twin model file",
    )
    parser.add_argument(
        "--springback", type=Path, metavar="RUN",
        help="fit the springback (a factor on the elastic recovery F/k_unload and the depth ratio kept) to this run's "
        "part scan against --design, the twin replaying its command (isf model); --write-model puts the fit into a "
        "twin model file (with --model's forces, e.g. from --forces on the same run)",
    )
    parser.add_argument("--design", type=Path, metavar="DESIGN", help="--springback: the part's design surface (STL)")
    parser.add_argument("--model", type=Path, help="--forces, --springback: start from this twin model file")


def run(args: argparse.Namespace) -> int:
    """Run the identification and report it."""
    from twin.apps.tasks.identify import IdentifyRequest, identify_task

    given = {name: getattr(args, name, None) for name in ("forces", "springback", "design", "model", "robot")}
    request = IdentifyRequest(args.method, args.loads, args.run_dir, **given, declaration=process_declaration(args),
                              force_model=getattr(args, "force_model", "auto"), write_model=args.write_model,
                              cell=getattr(args, "cell_record", None))
    inputs = (args.loads, args.run_dir, given["forces"], given["springback"], given["design"])
    return finish(args, identify_task(request, note), protect=inputs)
