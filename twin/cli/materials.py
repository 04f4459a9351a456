"""`tx200-twin materials`: the sheet-material library (or a user's materials file), each number with its source
(`twin.apps.tasks.materials`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.cli._common import add_json_argument, finish

HELP = "List the sheet materials (R_m, R_p0.2, E, ν, ρ, hardening law), each number's source and the bibliography."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `materials` options."""
    parser.add_argument(
        "--file", type=Path, metavar="FILE.toml", help="list a materials file of your own (same format as the library)"
    )
    add_json_argument(parser, "the materials and the bibliography")


def run(args: argparse.Namespace) -> int:
    """List the materials."""
    from twin.apps.tasks.materials import MaterialsRequest, materials_task
    from twin.process.material.file import library_path

    return finish(args, materials_task(MaterialsRequest(args.file)), protect=(args.file, library_path()))
