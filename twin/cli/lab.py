"""`tx200-twin lab`: make a measured run (or a Method 1 load-test file) on the virtual lab (`twin.apps.tasks.lab`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.cli._common import (
    add_force_model_argument,
    add_json_argument,
    add_placement_arguments,
    add_process_arguments,
    add_robot_argument,
    finish,
    note,
    placement_from,
    process_declaration,
)
from twin.cli._types import seed
from twin.sim.effects import EFFECTS
from twin.sim.online_settings import MAX_CORRECTION_HELP, MAX_RATE_HELP

HELP = "Run the virtual lab (richer plant, noise, hidden effects) and write a measured run."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `lab` options."""
    parser.add_argument("--scenario", required=True, choices=("nominal", "compensated", "loadtest", "cnc"))
    parser.add_argument("--commanded", type=Path,
                        help="commanded.csv-format path (required for compensated; default the groove)")
    effect_list = ", ".join(f"{name} [{spec.unit}] (acts on the {spec.acts_on})" for name, spec in EFFECTS.items())
    parser.add_argument(
        "--effect", action="append", metavar="NAME=VALUE", help=f"hidden effect, repeatable: {effect_list}"
    )
    parser.add_argument(
        "--plant", metavar="NAME", default="quasi-static",
        help="quasi-static: the twin plus hidden effects (default); dynamic: a MuJoCo mj_step plant "
        "(docs/dynamic-plant.md); or a plant registered in twin.apps.tasks.lab.LAB_PLANTS",
    )
    parser.add_argument(
        "--set", action="append", metavar="NAME=VALUE", help="dynamic plant knob, repeatable (docs/dynamic-plant.md lists them)"
    )
    parser.add_argument("--neutral", action="store_true", help="dynamic plant: start from the neutral knobs")
    parser.add_argument("--online", action="store_true", help="dynamic plant: its controller compensates online "
                        "each 4 ms cycle with the twin's compensator on the plant's F/T stream (docs/online.md)")
    parser.add_argument("--model", type=Path, help="with --online: the compensator's twin (a `learn`ed model file)")
    parser.add_argument("--max-correction-mm", type=float, metavar="MM", help=MAX_CORRECTION_HELP)
    parser.add_argument("--max-rate-mm-s", type=float, metavar="MM_S", help=MAX_RATE_HELP)
    parser.add_argument("--seed", type=seed, required=True, help="seed of the lab's noise")
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    add_placement_arguments(parser, "sheet placement (nominal and compensated runs; recorded in meta.json)")
    parser.add_argument("--out", type=Path, required=True, help="run directory (loadtest: a CSV file)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output")
    add_json_argument(parser, "a summary")


def run(args: argparse.Namespace) -> int:
    """Run the lab."""
    from twin.apps.tasks.lab import LabRequest, lab_task

    request = LabRequest(
        args.scenario, args.out, args.seed, args.commanded, tuple(args.effect or ()), args.plant,
        tuple(args.set or ()), args.neutral, args.force_model, process_declaration(args), args.robot,
        placement_from(args), args.overwrite, args.online, args.model, getattr(args, "cell_record", None),
        args.max_correction_mm, args.max_rate_mm_s,
    )
    return finish(args, lab_task(request, note), protect=(args.commanded, args.process, args.model))
