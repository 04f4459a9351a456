"""Options shared by several commands, and how a command ends: the FE force history and its symmetry declaration,
the ideal path, the sheet force model, the robot, the declared process (`--process`, `--material`,
`--thickness-mm`, `--tool-radius-mm`: `process_declaration`), the sheet's placement, the scheduler, `--json`; and
`finish` (a task's report printed, its JSON written, its exit code). Which twin a command runs is not decided
here: its task calls `twin.analysis.resolve.resolve_spec`."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from twin.apps.tasks.base import Report
from twin.base.jsonio import emit_json
from twin.cli._types import finite
from twin.process.force.registry import FORCE_MODELS
from twin.process.process_file import ProcessDeclaration, declare_process
from twin.process.toolpath.placement import Placement
from twin.robot.controller import CONTROLLER_DEFAULTS, ONLINE_LIMITS
from twin.robot.description import DEFAULT_ROBOT, shipped_robots


def add_history_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--history FILE --symmetry half|full [--unchecked-symmetry]`."""
    parser.add_argument("--history", type=Path, help="FE force history CSV (default: the shipped stand-in)")
    parser.add_argument("--symmetry", choices=("half", "full"),
                        help="REQUIRED with --history: half-symmetric or full FE model")
    parser.add_argument("--unchecked-symmetry", action="store_true",
                        help="skip the column-name check of --symmetry (only to reproduce the thesis's mistake)")


def add_ideal_argument(parser: argparse.ArgumentParser) -> None:
    """Add `--ideal FILE` (the ideal path U_ID; default: the thesis groove)."""
    parser.add_argument("--ideal", type=Path, help="ideal path U_ID as CSV t_s,x_mm,y_mm,z_mm (default: the groove)")


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


def add_robot_argument(parser: argparse.ArgumentParser | Any) -> None:
    """Add `--robot NAME|PATH` (a shipped robot, `tx200-twin robots`, or a robot description file) and `--cell
    CELL.toml` (the user's cell declared once: robot, tool, sheet, process; `apply_cell`)."""
    parser.add_argument(
        "--cell", type=Path, metavar="FILE.toml",
        help="your cell declared once (tx200-twin-cell/1: robot, tool, sheet placement, process); this command's "
        "own flags override it",
    )
    parser.add_argument(
        "--robot",
        metavar="NAME|PATH",
        help=f"the robot: a shipped one ({', '.join(sorted(shipped_robots()))}; `tx200-twin robots`) or a "
        "tx200-twin-robot/1 description file; default: a run's recorded robot, else the model file's, else "
        f"{DEFAULT_ROBOT}",
    )


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
    """What `--process` and the flags declare (`twin.process.process_file.declare_process`), over a `--cell`'s
    process; nothing for a command without them."""
    declared = declare_process(getattr(args, "process", None), getattr(args, "material", None),
                               getattr(args, "thickness_mm", None), getattr(args, "tool_radius_mm", None))
    cell = getattr(args, "cell_declaration", None)
    return declared if cell is None else declared.over(cell.process)


def apply_cell(args: argparse.Namespace) -> None:
    """Lay a `--cell` file under the command's own flags: each option the command has and the user left unset takes
    the cell's value (robot, sheet origin and yaw, tool length and mass; its process through `process_declaration`).
    `args.cell_record` is what runs and programs record of it; `args.cell_filled` names the options the cell filled
    in (`given` tells them from typed ones: `twin.analysis.resolve.PRECEDENCE`, a flag > a run > the cell). A
    `--robot` that names another robot than the cell's keeps the cell's process but not its sheet, tool and
    controller (they are the cell robot's), with a note. The controller's slots and online limits (`[controller]`;
    the limits only where the command corrects online) fill in as well; what neither gives takes
    `twin.robot.controller`'s default."""
    if getattr(args, "cell", None) is not None:
        _lay_cell(args)
    for name, value in CONTROLLER_DEFAULTS.items():  # what neither a flag nor the cell gives
        if hasattr(args, name) and getattr(args, name) is None:
            setattr(args, name, value)


def _lay_cell(args: argparse.Namespace) -> None:
    """`apply_cell` with a `--cell`: its values into the options left unset, `cell_record`, `cell_filled`."""
    from twin.process.cell_file import read_cell_file
    from twin.robot.description import load_robot

    cell = read_cell_file(args.cell)
    args.cell_declaration, args.cell_record = cell, cell.record()
    values: list[tuple[str, Any]] = [("robot", cell.robot)]
    typed_robot = getattr(args, "robot", None)
    if cell.robot is not None and typed_robot is not None and \
            load_robot(typed_robot).source != load_robot(cell.robot).source:
        note(f"note: --robot {typed_robot} is not the cell's robot {cell.robot} ({args.cell}): the cell's sheet "
             "placement, tool and controller are that robot's and are not used; its process is")
        args.cell_record = {**{k: v for k, v in args.cell_record.items() if k not in ("ft_sensor", "controller")},
                            "sheet": {}, "tool": {}}
    else:
        online = getattr(args, "online", True)  # `online` itself has no flag: it is online
        values += [("origin_mm", None if cell.origin_mm is None else list(cell.origin_mm)), ("yaw_deg", cell.yaw_deg),
                   ("tool_length_mm", cell.tool.length_mm), ("tool_mass_kg", cell.tool.mass_kg),
                   *((k, v) for k, v in cell.controller.items() if online or k not in ONLINE_LIMITS)]
    filled = set()
    for name, value in values:
        if value is not None and hasattr(args, name) and getattr(args, name) is None:
            setattr(args, name, value)
            filled.add(name)
    args.cell_filled = frozenset(filled)


def given(args: argparse.Namespace, name: str) -> Any:
    """Option `name` as the user typed it: None when left out or filled in by `--cell` (`apply_cell`)."""
    return None if name in getattr(args, "cell_filled", frozenset()) else getattr(args, name, None)


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
    place.add_argument("--yaw-deg", type=finite, help="sheet yaw about the base z axis [deg] (default: a run's, else "
                       "the cell's, else 0; an explicit 0 overrides them)")
    return place


def placement_from(args: argparse.Namespace) -> Placement:
    """The `Placement` of `--origin-mm` / `--yaw-deg`."""
    origin = None if args.origin_mm is None else (args.origin_mm[0] / 1e3, args.origin_mm[1] / 1e3, args.origin_mm[2] / 1e3)
    return Placement(origin_base_m=origin, yaw_rad=math.radians(args.yaw_deg or 0.0))


def placement_given(args: argparse.Namespace) -> Placement | None:
    """The `Placement` of `--origin-mm` / `--yaw-deg` when either was given, else None (the model's or run's)."""
    return placement_from(args) if args.origin_mm is not None or args.yaw_deg is not None else None


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
