"""`tx200-twin lab`: make a measured run (or a Method 1 load-test file) on the virtual lab."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import TextIO

import numpy as np

from twin.analysis.compensation_record import read_record
from twin.analysis.identify.cartesian import THESIS_TABLE_4_2_LOADS_N
from twin.base.csvio import write_table
from twin.base.jsonio import emit_json
from twin.base.signals import interp_rows
from twin.cli._common import (
    add_force_model_argument,
    add_json_argument,
    add_placement_arguments,
    add_process_arguments,
    add_robot_argument,
    command_process,
    command_robot,
    placement_from,
    tool_path,
)
from twin.cli._types import seed
from twin.errors import InputError
from twin.process.description import Process
from twin.process.process_file import process_record
from twin.process.toolpath.placement import Placement
from twin.runs.read import lab_commanded
from twin.runs.write import write_run
from twin.sim.effects import EFFECTS, parse_effect_args
from twin.sim.spec import TwinSpec

HELP = "Run the virtual lab (richer plant, noise, hidden effects) and write a measured run."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `lab` options."""
    parser.add_argument("--scenario", required=True, choices=("nominal", "compensated", "loadtest", "cnc"))
    parser.add_argument(
        "--commanded", type=Path, help="commanded.csv-format path (required for compensated; default the groove)"
    )
    effect_list = ", ".join(f"{name} [{spec.unit}] (acts on the {spec.acts_on})" for name, spec in EFFECTS.items())
    parser.add_argument(
        "--effect", action="append", metavar="NAME=VALUE", help=f"hidden effect, repeatable: {effect_list}"
    )
    parser.add_argument(
        "--plant",
        choices=("quasi-static", "dynamic"),
        default="quasi-static",
        help="quasi-static: the twin plus hidden effects (default); dynamic: a MuJoCo mj_step plant "
        "(docs/dynamic-plant.md)",
    )
    parser.add_argument(
        "--set", action="append", metavar="NAME=VALUE", help="dynamic plant knob, repeatable (docs/dynamic-plant.md lists them)"
    )
    parser.add_argument("--neutral", action="store_true", help="dynamic plant: start from the neutral knobs")
    parser.add_argument("--seed", type=seed, required=True, help="seed of the lab's noise")
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    add_placement_arguments(parser, "sheet placement (nominal and compensated runs; recorded in meta.json)")
    parser.add_argument("--out", type=Path, required=True, help="run directory (loadtest: a CSV file)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output")
    add_json_argument(parser, "a summary")


def _check_out(out: Path, overwrite: bool) -> None:
    """Refuse an existing output before any simulation is spent on it."""
    if overwrite or not out.exists():
        return
    if out.is_dir() and not any(out.iterdir()):
        return
    raise InputError(f"{out} exists; pass --overwrite to replace it or choose another --out")


def run(args: argparse.Namespace) -> int:
    """Run the lab."""
    placement = placement_from(args)
    if not placement.is_default and args.scenario in ("loadtest", "cnc"):
        raise InputError(
            f"--origin-mm/--yaw-deg place the sheet for nominal and compensated runs; --scenario {args.scenario} "
            "keeps the cell's sheet_origin, yaw 0"
        )
    declared = [args.process, args.material, args.thickness_mm, args.tool_radius_mm]
    if args.scenario == "loadtest" and any(value is not None for value in declared):
        raise InputError(
            "--scenario loadtest loads the tool at home, with no sheet: --process, --material, --thickness-mm and "
            "--tool-radius-mm apply to the runs that form one (nominal, compensated, cnc)"
        )
    if args.plant == "dynamic":
        return _run_dynamic(args, placement)
    if args.set or args.neutral:
        raise InputError("--set and --neutral are knobs of --plant dynamic; the quasi-static lab takes --effect")
    effects = parse_effect_args(args.effect)
    _check_out(args.out, args.overwrite)
    out = sys.stderr if args.json == "-" else sys.stdout  # keep stdout pure JSON for `--json -`
    if args.scenario == "loadtest":
        return _run_load_test(args, TwinSpec(robot=command_robot(args), effects=effects), out)
    if args.scenario == "cnc":
        return _run_cnc(args, effects_given=bool(args.effect), out=out)
    commanded, protect = lab_commanded(args.scenario, args.commanded)
    t_s, p_cmd = commanded.t_s, commanded.values
    spec = TwinSpec(robot=command_robot(args), process=command_process(args, Process(), p_cmd), placement=placement,
                    effects=effects)
    from twin.lab.virtual import run_lab

    run_, truth = run_lab(t_s, p_cmd, scenario=args.scenario, seed=args.seed, spec=spec)
    record = read_record(args.commanded) if args.commanded is not None else None
    if record is not None:  # what the compensation used travels with the run, for `check`
        run_ = replace(run_, meta={**run_.meta, "compensation": record.to_json()})
    write_run(args.out, run_, truth=truth, overwrite=args.overwrite, protect=protect)
    deflection = np.max(np.linalg.norm(run_.tracker.values - interp_rows(run_.tracker.t_s, t_s, p_cmd), axis=1))
    summary = {
        "scenario": args.scenario,
        "out": args.out,
        "seed": args.seed,
        "tracker_samples": len(run_.tracker.t_s),
        "force_samples": len(run_.forces.t_s) if run_.forces is not None else 0,
        "measured_deviation_max_mm": 1e3 * float(deflection),
        "peak_force_n": float(np.max(np.linalg.norm(run_.forces.values, axis=1))) if run_.forces else 0.0,
        "peak_fz_n": float(np.max(run_.forces.values[:, 2])) if run_.forces else 0.0,
        "process": {**process_record(spec.process), "force_model": spec.process.force_model},
    }
    print(
        f"lab {args.scenario}: {summary['tracker_samples']} tracker / "
        f"{summary['force_samples']} force samples, "
        f"max |measured - commanded| {summary['measured_deviation_max_mm']:.2f} mm, "
        f"peak |F| {summary['peak_force_n']:.0f} N -> {args.out}",
        file=out,
    )
    emit_json(args.json, summary)
    return 0


def _run_load_test(args: argparse.Namespace, spec: TwinSpec, out: TextIO) -> int:
    """Thesis Method 1's load cases (Table 4.2) at home, the deflections measured: a CSV for `identify --method 1`."""
    from twin.lab.virtual import load_test

    loads, deflections = load_test(THESIS_TABLE_4_2_LOADS_N, seed=args.seed, spec=spec)
    columns = {"fx_n": loads[:, 0], "fy_n": loads[:, 1], "fz_n": loads[:, 2]}
    columns |= {f"d{a}_mm": 1e3 * deflections[:, i] for i, a in enumerate("xyz")}
    write_table(args.out, columns, formats={name: (".1f" if name.startswith("f") else ".5f") for name in columns})
    print(f"lab loadtest: {len(loads)} load cases at home (thesis Table 4.2) -> {args.out}", file=out)
    emit_json(args.json, {"scenario": "loadtest", "out": args.out, "cases": len(loads)})
    return 0


def _run_cnc(args: argparse.Namespace, *, effects_given: bool, out: TextIO) -> int:
    """The thesis's CNC validation (§2.3) on a rigid machine: the groove, or any path of `--commanded`, formed with
    the declared process; forces at 10 Hz, the part after springback (the y = 0 section, and a scan of the surface
    where the force model keeps one)."""
    if effects_given:
        raise InputError("--scenario cnc is the rigid machine: robot effects (--effect) do not apply")
    commanded, protect = lab_commanded(args.scenario, args.commanded)
    path = tool_path(commanded)
    process = command_process(args, Process(), path.p_sheet_m)
    from twin.lab.cnc import run_cnc

    run_, truth = run_cnc(seed=args.seed, path=path, process=process)
    write_run(args.out, run_, truth=truth, overwrite=args.overwrite, protect=protect)
    assert run_.part_profile is not None and run_.forces is not None
    summary = {
        "scenario": "cnc",
        "out": args.out,
        "seed": args.seed,
        "force_samples": len(run_.forces.t_s),
        "peak_fz_n": float(np.max(run_.forces.values[:, 2])),
        "formed_depth_mm": -1e3 * float(np.min(run_.part_profile[1])),
        "process": {**process_record(process), "force_model": process.force_model},
    }
    print(
        f"lab cnc: rigid machine, {summary['force_samples']} force samples at 10 Hz, "
        f"peak Fz {summary['peak_fz_n']:.0f} N, formed depth after springback "
        f"{summary['formed_depth_mm']:.2f} mm ({process.material}, {1e3 * process.thickness_m:g} mm, "
        f"{process.force_model} model) -> {args.out}",
        file=out,
    )
    emit_json(args.json, summary)
    return 0


def _run_dynamic(args: argparse.Namespace, placement: Placement) -> int:
    """`--plant dynamic`: the MuJoCo mj_step plant with its own sensor chain (twin.lab.dynamic)."""
    from twin.lab.dynamic.cli_support import run_dynamic_command

    if args.effect:
        raise InputError("--plant dynamic takes no --effect: its effects are physical knobs, set with --set NAME=VALUE")
    if args.scenario == "cnc":
        raise InputError("--scenario cnc is the rigid machine; it does not apply to --plant dynamic (a robot)")
    _check_out(args.out, args.overwrite)
    process = Process()
    if args.scenario != "loadtest":
        commanded, _ = lab_commanded(args.scenario, args.commanded)
        process = command_process(args, process, commanded.values)
    record = read_record(args.commanded) if args.commanded is not None else None
    return run_dynamic_command(args, loads_n=THESIS_TABLE_4_2_LOADS_N, process=process, placement=placement,
                               robot=command_robot(args),
                               meta=None if record is None else {"compensation": record.to_json()})
