"""Options shared by several commands: the FE force history and its symmetry declaration, the ideal path, the
sheet force model, the declared process (`--process`, `--material`, `--thickness-mm`, `--tool-radius-mm`), the
sheet's placement and the twin they make (`spec_from_arguments`)."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from twin.analysis.resolve import resolve_process, resolve_robot, resolve_spec
from twin.apps.tasks.base import Report
from twin.base.jsonio import emit_json
from twin.cli._types import finite
from twin.errors import InputError
from twin.process.description import Process
from twin.process.fe.load import ForceHistory, default_force_history, load_force_history
from twin.process.force.registry import FORCE_MODELS
from twin.process.process_file import ProcessDeclaration, declare_process
from twin.process.toolpath.groove import ToolPath, groove_path, label_passes
from twin.process.toolpath.placement import Placement
from twin.robot.description import DEFAULT_ROBOT, RobotDescription, shipped_robots
from twin.runs.format import Run, Stream
from twin.runs.read import read_commanded_csv
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


def spec_from_arguments(
    args: argparse.Namespace,
    p_sheet_m: Any,
    *,
    run: Run | None = None,
    history: ForceHistory | None = None,
) -> TwinSpec:
    """The twin of a command (`twin.analysis.resolve.resolve_spec`) from its options: `--model`, `--robot`,
    the process options, `--force-model` and the placement options, where the command has them."""
    given = getattr(args, "origin_mm", None) is not None or getattr(args, "yaw_deg", 0.0) != 0.0
    return resolve_spec(
        model=getattr(args, "model", None), robot=getattr(args, "robot", None), run=run,
        declaration=process_declaration(args), force_model_name=getattr(args, "force_model", "auto"),
        placement=placement_from(args) if given else None, history=history, p_sheet_m=p_sheet_m, note=note,
    )


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
    """The robot of a command (`twin.analysis.resolve.resolve_robot` of `--robot`)."""
    return resolve_robot(getattr(args, "robot", None), model_robot, run)


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
    """What `--process` and the flags declare (`twin.process.process_file.declare_process`); nothing for a
    command without them."""
    return declare_process(getattr(args, "process", None), getattr(args, "material", None),
                           getattr(args, "thickness_mm", None), getattr(args, "tool_radius_mm", None))


def command_process(
    args: argparse.Namespace, base: Process, p_sheet_m: Any, meta: Mapping[str, Any] | None = None
) -> Process:
    """The process a command runs (`twin.analysis.resolve.resolve_process` of its options)."""
    return resolve_process(base, process_declaration(args), getattr(args, "force_model", "auto"), p_sheet_m,
                           meta, note=note)


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


def finish(args: argparse.Namespace, report: Report, protect: Sequence[str | Path | None] = ()) -> int:
    """Print a task's report (stdout; stderr when `--json -` keeps stdout for the JSON), write its `--json`, and
    return its exit code. `protect`: the inputs the JSON must not replace (None entries skipped)."""
    json_target = getattr(args, "json", None)
    out = sys.stderr if json_target == "-" else sys.stdout
    for line in report.lines():
        print(line, file=out)
    emit_json(json_target, report.record(), protect=[p for p in protect if p is not None])
    return report.exit_code


def note(text: str) -> None:
    """A task's `Note` on the command line: stderr."""
    print(text, file=sys.stderr)
