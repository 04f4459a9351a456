"""Options shared by several commands: the FE force history and its symmetry declaration, the ideal path, the
sheet force model, the declared process (`--process`, `--material`, `--thickness-mm`, `--tool-radius-mm`), the
sheet's placement and the twin they make (`spec_from_arguments`)."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from twin.cli._types import finite
from twin.errors import InputError
from twin.process.description import Process
from twin.process.fe.load import ForceHistory, default_force_history, load_force_history
from twin.process.force.registry import FORCE_MODELS, auto_force_model, force_model
from twin.process.material.library import material
from twin.process.process_file import ProcessDeclaration, positive, read_process_declaration
from twin.process.toolpath.groove import ToolPath, groove_path, label_passes
from twin.process.toolpath.placement import Placement
from twin.robot.description import DEFAULT_ROBOT, RobotDescription, load_robot, shipped_robots
from twin.runs.format import Run, Stream, run_placement, run_process, run_robot
from twin.runs.read import read_commanded_csv
from twin.sim.model_file import read_model_file
from twin.sim.spec import TwinSpec


def add_history_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--history FILE --symmetry half|full [--unchecked-symmetry]`."""
    parser.add_argument("--history", type=Path, help="FE force history CSV (default: the shipped stand-in)")
    parser.add_argument(
        "--symmetry",
        choices=("half", "full"),
        help="REQUIRED with --history: half-symmetric or full FE model",
    )
    parser.add_argument(
        "--unchecked-symmetry",
        action="store_true",
        help="skip the column-name check of --symmetry (only to reproduce the thesis's mistake)",
    )


def history_from_arguments(args: argparse.Namespace) -> tuple[ForceHistory, ForceHistory]:
    """The history as declared, and the physical reference (symmetry implied by the column names).

    Returns:
        (declared, reference): equal unless `--unchecked-symmetry` let a contradicting declaration through.
    """
    if args.history is None:
        if args.symmetry is not None:
            raise InputError("--symmetry is only meaningful with --history FILE")
        history = default_force_history()
        return history, history
    if args.symmetry is None:
        raise InputError(
            f"--history {args.history} needs --symmetry half|full: a half-symmetric FE model's forces must be "
            "doubled (thesis sec. 2.2); forgetting it broke the thesis's compensated run (sec. 5.1)"
        )
    declared = load_force_history(
        args.history, symmetry=args.symmetry, trust_columns=not args.unchecked_symmetry
    )
    if declared.column_symmetry == declared.symmetry:
        return declared, declared
    return declared, load_force_history(args.history, symmetry=declared.column_symmetry)


def add_ideal_argument(parser: argparse.ArgumentParser) -> None:
    """Add `--ideal FILE` (the ideal path U_ID; default: the thesis groove)."""
    parser.add_argument(
        "--ideal", type=Path, help="ideal path U_ID as CSV t_s,x_mm,y_mm,z_mm (default: the groove)"
    )


def ideal_from_arguments(args: argparse.Namespace) -> ToolPath:
    """The ideal path U_ID from `--ideal` or the default groove."""
    if args.ideal is None:
        return groove_path()
    return tool_path(read_commanded_csv(args.ideal))


def tool_path(stream: Stream) -> ToolPath:
    """A commanded or ideal path read from a file as a `ToolPath`, its passes labelled by its x reversals."""
    pass_index, direction = label_passes(stream.values[:, 0])
    return ToolPath(t_s=stream.t_s, p_sheet_m=stream.values, pass_index=pass_index, direction=direction)


def add_json_argument(parser: argparse.ArgumentParser | Any, what: str) -> None:
    """Add `--json FILE` (the command's numbers as a JSON document; `-`: stdout, the summary then on stderr)."""
    parser.add_argument("--json", metavar="FILE", help=f"write {what} as JSON to FILE ('-' for stdout)")


def add_force_model_argument(parser: argparse.ArgumentParser) -> None:
    """Add `--force-model auto|<registered model>` (the sheet force model of the twin or lab)."""
    listing = "; ".join(f"'{m.name}': {m.description}" for m in FORCE_MODELS.values())
    parser.add_argument(
        "--force-model",
        choices=("auto", *FORCE_MODELS),
        default="auto",
        help=f"sheet force model: {listing}; 'auto' (default): the model a run records, else the first that "
        "applies to the path",
    )


def force_model_for(
    args: argparse.Namespace,
    process: Process,
    p_sheet_m: Any,
    meta: Mapping[str, Any] | None = None,
    declared: str | None = None,
    fitted: str | None = None,
) -> str:
    """The force model of `--force-model`: a named one, or for `auto` the one a process file declares
    (`declared`), else the one a model file fitted to its cell (`fitted`: `learn`, `identify --forces`), else the
    one a run's `meta.json` records, else the first registered model that applies to the path
    (`twin.process.force.registry.auto_force_model`)."""
    if args.force_model != "auto":
        return str(force_model(args.force_model).name)
    if declared is not None:
        return declared
    if fitted is not None:
        return fitted
    recorded = None if meta is None else meta.get("force_model")
    if isinstance(recorded, str) and recorded in FORCE_MODELS:
        return recorded
    return auto_force_model(process, np.asarray(p_sheet_m, dtype=float))


def spec_from_arguments(
    args: argparse.Namespace,
    p_sheet_m: Any,
    *,
    run: Run | None = None,
    history: ForceHistory | None = None,
) -> TwinSpec:
    """The twin of a command: the model file of `--model` (or the default cell), with the FE history, the process
    (the model file's, under a run's recorded one, under `--process`, under the flags: `command_process`), the
    force model (`force_model_for`) and the placement (a run's own, else `--origin-mm`/`--yaw-deg` where the
    command has them, else the model file's).

    Args:
        args: The parsed options (`model`, `force_model`, and the placement options where present).
        p_sheet_m: The commanded or ideal path the twin will drive, sheet frame [m], shape (n, 3).
        run: The run the twin replays (its placement and recorded force model), or None.
        history: The FE history (as declared) when the command takes one; None: the model file's or the shipped.
    """
    model = getattr(args, "model", None)
    base = read_model_file(model) if model is not None else TwinSpec()
    base = base.replace(robot=command_robot(args, base.robot if model is not None else None, run))
    process = base.process if history is None else replace(base.process, history=history)
    name = "the model file's process" if model is not None else None
    if run is not None and "process" in run.meta:
        process = run_process(run.meta, process, (run.directory or Path(".")) / "meta.json")
        name = "the run's recorded process"
    fitted = base.process.force_model if model is not None and base.process.force_fit else None
    process = command_process(args, process, p_sheet_m, None if run is None else run.meta, name, fitted)
    if run is not None:
        placement = run_placement(run.meta)
    elif getattr(args, "origin_mm", None) is not None or getattr(args, "yaw_deg", 0.0) != 0.0:
        placement = placement_from(args)
    else:
        placement = base.placement
    return base.replace(process=process, placement=placement)


def add_robot_argument(parser: argparse.ArgumentParser | Any) -> None:
    """Add `--robot NAME|PATH` (a shipped robot, `tx200-twin robots`, or a robot description file)."""
    parser.add_argument(
        "--robot",
        metavar="NAME|PATH",
        help=f"the robot: a shipped one ({', '.join(sorted(shipped_robots()))}; `tx200-twin robots`) or a "
        "tx200-twin-robot/1 description file; default: a run's recorded robot, else the model file's, else "
        f"{DEFAULT_ROBOT}",
    )


def command_robot(
    args: argparse.Namespace, model_robot: RobotDescription | None = None, run: Run | None = None
) -> RobotDescription:
    """The robot of a command: a run's recorded one (which `--robot` and a model file must match), else
    `--robot`, else the model file's, else the default.

    Raises:
        InputError: `--robot` or the model file names another robot than the run was made with.
        ModelError: An unknown robot name or a bad description file.
    """
    given = getattr(args, "robot", None)
    chosen = load_robot(given) if given is not None else None
    if run is not None:
        recorded = run_robot(run.meta, (run.directory or Path(".")) / "meta.json")
        for what, other in (("--robot", chosen), ("the model file", model_robot)):
            if other is not None and other.source != recorded.source:
                raise InputError(f"{what} gives robot {other.name!r}, but the run {run.directory} was made with "
                                 f"{recorded.name!r}: a twin of another robot cannot replay it")
        return recorded
    return chosen or model_robot or load_robot()


def add_process_arguments(parser: argparse.ArgumentParser) -> Any:
    """Add `--process FILE.toml`, `--material NAME`, `--thickness-mm T`, `--tool-radius-mm R`; returns their group."""
    group = parser.add_argument_group(
        "process (the sheet and the tool; a flag overrides --process, which overrides the model file's or the "
        "run's process, else the thesis's: AA5086-H111, 1 mm, R 7.5 mm)"
    )
    group.add_argument(
        "--process", type=Path, metavar="FILE.toml", help="a process file (tx200-twin-process/1: material, "
        "material_file, thickness_mm, tool_radius_mm, tool_friction, force_model)"
    )
    group.add_argument("--material", metavar="NAME", help="sheet material of the library (`tx200-twin materials`)")
    group.add_argument("--thickness-mm", type=finite, metavar="T", help="sheet thickness [mm]")
    group.add_argument("--tool-radius-mm", type=finite, metavar="R", help="tool radius [mm], larger than the thickness")
    return group


def process_declaration(args: argparse.Namespace) -> ProcessDeclaration:
    """What `--process` and the flags declare (the flags over the file); nothing for a command without them.

    Raises:
        InputError: An unknown `--material`, a length that is not > 0 (naming the option).
        DataFileError: A bad process file (naming the file and the key).
    """
    file = getattr(args, "process", None)
    declared = ProcessDeclaration() if file is None else read_process_declaration(file)
    flags: dict[str, Any] = {}
    origins: dict[str, str] = {}
    if getattr(args, "material", None) is not None:
        try:
            flags["material"] = material(args.material)
        except InputError as exc:
            raise InputError(f"--material {args.material}: {exc}") from None
    for option, name in (("--thickness-mm", "thickness_m"), ("--tool-radius-mm", "tool_radius_m")):
        value = getattr(args, option.lstrip("-").replace("-", "_"), None)
        if value is not None:
            flags[name] = positive(option, value) / 1e3
            origins[name] = f"{option} {value:g}"
    return ProcessDeclaration(**flags, origins=tuple(origins.items())).over(declared)


def process_from_arguments(args: argparse.Namespace, base: Process) -> Process:
    """`base` with what `--process` and the flags declare (`process_declaration`); the force model as declared.

    Raises:
        InputError: A bad flag, or a tool not larger than the sheet is thick (naming where each came from).
    """
    return process_declaration(args).applied_to(base)


def command_process(
    args: argparse.Namespace,
    base: Process,
    p_sheet_m: Any,
    meta: Mapping[str, Any] | None = None,
    base_name: str | None = None,
    fitted: str | None = None,
) -> Process:
    """The process a command runs: `base` (a model file's, a run's; `base_name` says which, for messages), the
    declared process over it (`process_from_arguments`), and its force model (`force_model_for`: `--force-model`,
    else the process file's, else a run's recorded one, else the first that applies to the path)."""
    declaration = process_declaration(args)
    process = declaration.applied_to(base, base_name)
    chosen = force_model_for(args, process, p_sheet_m, meta, declared=declaration.force_model, fitted=fitted)
    if chosen == "table" and _differs_from_history(process):
        print(
            f"note: the 'table' force model plays back the FE history's forces; the declared sheet "
            f"({process.material}, R_m {process.tensile_strength_mpa:g} MPa, {1e3 * process.thickness_m:g} mm) is "
            "recorded but does not change them",
            file=sys.stderr,
        )
    return replace(process, force_model=chosen)


def _differs_from_history(process: Process) -> bool:
    """Whether the process's sheet is not the thesis's, whose forces the shipped FE history holds."""
    default = Process()
    return process.history is None and (
        process.tensile_strength_mpa != default.tensile_strength_mpa or process.thickness_m != default.thickness_m
    )


def add_placement_arguments(parser: argparse.ArgumentParser | Any, title: str = "sheet placement") -> Any:
    """Add `--origin-mm X Y Z` and `--yaw-deg` (the sheet frame in the robot base); returns their group."""
    place = parser.add_argument_group(title)
    place.add_argument(
        "--origin-mm",
        type=finite,
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="sheet origin in the robot base frame [mm] (default: the cell's sheet_origin)",
    )
    place.add_argument("--yaw-deg", type=finite, default=0.0, help="sheet yaw about the base z axis [deg] (default 0)")
    return place


def placement_from(args: argparse.Namespace) -> Placement:
    """The `Placement` of `--origin-mm` / `--yaw-deg`."""
    origin = None if args.origin_mm is None else (args.origin_mm[0] / 1e3, args.origin_mm[1] / 1e3, args.origin_mm[2] / 1e3)
    return Placement(origin_base_m=origin, yaw_rad=math.radians(args.yaw_deg))


def add_scheduler_argument(parser: argparse.ArgumentParser) -> None:
    """Add `--scheduler ADDRESS` (a Dask distributed scheduler to run the command's jobs on)."""
    parser.add_argument(
        "--scheduler", metavar="ADDRESS",
        help="run the jobs on the Dask distributed cluster of this scheduler (e.g. tcp://HOST:8786; its workers "
        "need tx200-twin installed); default: local processes on every usable core (--workers)",
    )
