"""The twin a task runs: one rule for whose robot, placement, process and force model win.

Every command, and every Python caller that replays, compensates or learns, needs the same answer to "which
twin?": a run's recorded robot and placement win (a twin of another robot cannot replay it, and a placement is a
fact of the run), the declared process goes over the model file's or the run's, and the force model is the one
named, else the process file's, else the one a model file fitted to its cell, else the run's recorded one, else
the first registered model that applies to the path. The rule lives here once; `replay` and the CLI call it.

Where the sheet lies (`resolve_placement`) and which tool is on the flange (`twin.analysis.tool_choice`) follow one
precedence, each value on its own (`PRECEDENCE`): an explicit flag > the run's record > the cell file > the model file > the
robot's defaults. An explicit flag is one the user typed (`--yaw-deg 0` included), not a default nor a value the
cell file filled in (`twin.cli._common.apply_cell`). A run records a placement (`meta.json`'s `placement`; absent:
the robot's default sheet origin, yaw 0) and a tool (its `cell` record's tool, else `tool_length_m` and an import's
sensor `tool_mass_kg`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.tool_choice import (
    Chosen,
    cell_words,
    first_given,
    resolve_tool_spec,
)
from twin.errors import InputError
from twin.process.description import Process
from twin.process.fe.load import ForceHistory
from twin.process.force.registry import FORCE_MODELS, auto_force_model, force_model
from twin.process.process_file import ProcessDeclaration
from twin.process.toolpath.placement import Placement
from twin.robot.description import load_robot
from twin.robot.facts import RobotDescription
from twin.runs.format import Run, run_placement, run_process, run_robot
from twin.sim.model_file import read_model_file
from twin.sim.spec import TwinSpec

AUTO = "auto"
@dataclass(frozen=True)
class PlacementChoice:
    """The sheet placement chosen, and where its origin and its yaw came from (in words)."""

    placement: Placement
    origin_from: str
    yaw_from: str


def resolve_placement(
    *,
    origin_mm: Sequence[float] | None = None,
    yaw_deg: float | None = None,
    run: Run | None = None,
    cell: Mapping[str, Any] | None = None,
    model: Placement | None = None,
    robot_name: str = "the robot",
) -> PlacementChoice:
    """The sheet placement by `PRECEDENCE`, origin and yaw each on its own.

    Args:
        origin_mm: `--origin-mm` as typed [mm], or None.
        yaw_deg: `--yaw-deg` as typed [deg] (0 included), or None.
        run: The run the command is for: its recorded placement (absent: the robot's default origin, yaw 0).
        cell: A cell file's record (`CellDeclaration.record`: its `sheet` `origin_mm`, `yaw_deg`), or None.
        model: A model file's placement, or None.
        robot_name: The robot, for the words of "its default sheet origin".
    """
    run_place = None if run is None else run_placement(run.meta, (run.directory or Path(".")) / "meta.json")
    run_name = None if run is None else f"the run {run.directory}"
    sheet = {} if cell is None else dict(cell.get("sheet") or {})
    cell_name = cell_words(cell)
    default = Chosen(None, f"robot {robot_name}'s default sheet origin")
    origin = first_given([
        ("--origin-mm", origin_mm is not None, None if origin_mm is None else tuple(float(v) / 1e3 for v in origin_mm)),
        (f"{run_name}" + ("" if run_place is None or run_place.origin_base_m is not None else
                          f" (robot {robot_name}'s default sheet origin)"), run_place is not None,
         None if run_place is None else run_place.origin_base_m),
        (cell_name, sheet.get("origin_mm") is not None,
         None if sheet.get("origin_mm") is None else tuple(float(v) / 1e3 for v in sheet["origin_mm"])),
        ("the model file", model is not None and model.origin_base_m is not None, None if model is None else
         model.origin_base_m),
    ], default)
    yaw = first_given([
        ("--yaw-deg", yaw_deg is not None, None if yaw_deg is None else math.radians(yaw_deg)),
        (f"{run_name}", run_place is not None, None if run_place is None else run_place.yaw_rad),
        (cell_name, sheet.get("yaw_deg") is not None, math.radians(float(sheet.get("yaw_deg") or 0.0))),
        ("the model file", model is not None, None if model is None else model.yaw_rad),
    ], Chosen(0.0, "the default"))
    return PlacementChoice(Placement(origin_base_m=origin.value, yaw_rad=float(yaw.value)), origin.source, yaw.source)


def choose_force_model(
    name: str,
    process: Process,
    p_sheet_m: Any,
    meta: Mapping[str, Any] | None = None,
    declared: str | None = None,
    fitted: str | None = None,
) -> str:
    """The force model a task runs.

    Args:
        name: A registered model's name, or "auto".
        process: The process (its material and tool decide which model applies to the path).
        p_sheet_m: The path the twin will drive, sheet frame [m], shape (n, 3).
        meta: A run's `meta.json` (its recorded `force_model`), or None.
        declared: The force model a process file declares, or None.
        fitted: The force model a model file fitted to its cell (`learn`, `identify --forces`), or None.

    Returns:
        `name` when it is not "auto"; else `declared`, `fitted`, the run's recorded one, or the first registered
        model that applies to the path (`auto_force_model`), in that order.

    Raises:
        InputError: An unknown model name (naming the registered ones).
    """
    if name != AUTO:
        return str(force_model(name).name)
    recorded = None if meta is None else meta.get("force_model")
    for chosen in (declared, fitted, recorded if recorded in FORCE_MODELS else None):
        if isinstance(chosen, str):
            return chosen
    return auto_force_model(process, np.asarray(p_sheet_m, dtype=float))


def resolve_robot(
    robot: str | Path | RobotDescription | None = None,
    model_robot: RobotDescription | None = None,
    run: Run | None = None,
    label: str = "--robot",
) -> RobotDescription:
    """The robot of a task: a run's recorded one (which `robot` and a model file's must match), else `robot`,
    else the model file's, else the default.

    Raises:
        InputError: `robot` (said as `label`) or the model file names another robot than the run was made with.
        ModelError: An unknown robot name or a bad description file.
    """
    chosen = load_robot(robot) if isinstance(robot, (str, Path)) else robot
    if run is None:
        return chosen or model_robot or load_robot()
    recorded = run_robot(run.meta, (run.directory or Path(".")) / "meta.json")
    for what, other in ((label, chosen), ("the model file", model_robot)):
        if other is not None and other.source != recorded.source:
            raise InputError(f"{what} gives robot {other.name!r}, but the run {run.directory} was made with "
                             f"{recorded.name!r}: a twin of another robot cannot replay it")
    return recorded


def resolve_spec(
    *,
    model: str | Path | TwinSpec | None = None,
    robot: str | Path | RobotDescription | None = None,
    run: Run | None = None,
    declaration: ProcessDeclaration | None = None,
    force_model_name: str = AUTO,
    placement: Placement | None = None,
    history: ForceHistory | None = None,
    p_sheet_m: Any = None,
    note: Callable[[str], None] | None = None,
    cell: Mapping[str, Any] | None = None,
) -> TwinSpec:
    """The twin a task runs, from what its user gave.

    Args:
        model: A model file (path) or a spec; None: the default cell.
        robot: A robot name, description file or description; None: the run's, else the model's, else the default.
        run: The run the twin replays or learns from (its robot, placement and recorded process win), or None.
        declaration: The process a user declared (a process file and flags), over the model's or the run's.
        force_model_name: A registered force model, or "auto" (`choose_force_model`).
        placement: The sheet's placement a user gave (its origin when set, and its yaw), over the run's and the
            model's (`resolve_placement`); None: the run's, else the model's.
        history: The FE force history (as declared), or None for the model's or the shipped one.
        p_sheet_m: The path the twin will drive, sheet frame [m], shape (n, 3): what "auto" looks at. None: the
            run's commanded path.
        note: Where to say a choice the user may not expect (a table model that ignores a declared sheet).
        cell: A cell file's record (`CellDeclaration.record`): its tool is simulated (`resolve_tool_spec`: the
            run's tool, else the cell's, else the model file's, else the robot model's own), or None.

    Raises:
        InputError: Another robot than the run's, an unknown force model, a bad declaration (naming its origin).
    """
    given = model if isinstance(model, TwinSpec) else read_model_file(model) if model is not None else None
    base = given or TwinSpec()
    base = base.replace(robot=resolve_robot(robot, base.robot if given is not None else None, run))
    process = base.process if history is None else replace(base.process, history=history)
    name = "the model file's process" if given is not None else None
    if run is not None and "process" in run.meta:
        process = run_process(run.meta, process, (run.directory or Path(".")) / "meta.json")
        name = "the run's recorded process"
    if p_sheet_m is None and run is not None:
        p_sheet_m = run.commanded.values
    fitted = base.process.force_model if given is not None and base.process.force_fit else None
    process = resolve_process(process, declaration, force_model_name, p_sheet_m,
                              None if run is None else run.meta, name, fitted, note)
    chosen = resolve_placement(
        origin_mm=None if placement is None or placement.origin_base_m is None else
        [1e3 * v for v in placement.origin_base_m],
        yaw_deg=None if placement is None else math.degrees(placement.yaw_rad),
        run=run, model=base.placement if given is not None else None, robot_name=base.robot.name,
    )
    tool = resolve_tool_spec(base.robot, run=run, cell=cell, model=base.tool if given is not None else None)
    return base.replace(process=process, placement=chosen.placement, tool=tool)


def resolve_process(
    base: Process,
    declaration: ProcessDeclaration | None = None,
    force_model_name: str = AUTO,
    p_sheet_m: Any = None,
    meta: Mapping[str, Any] | None = None,
    base_name: str | None = None,
    fitted: str | None = None,
    note: Callable[[str], None] | None = None,
) -> Process:
    """The process a task runs: the declaration over `base` (a model file's, a run's: `base_name` says which, for
    messages) and its force model (`choose_force_model`).

    Raises:
        InputError: A bad declaration (naming where each value came from), an unknown force model.
    """
    declaration = declaration or ProcessDeclaration()
    process = declaration.applied_to(base, base_name)
    p_sheet_m = np.zeros((1, 3)) if p_sheet_m is None else p_sheet_m
    chosen = choose_force_model(force_model_name, process, p_sheet_m, meta, declaration.force_model, fitted)
    if chosen == "table" and note is not None and _differs_from_history(process):
        note(f"note: the 'table' force model plays back the FE history's forces; the declared sheet "
             f"({process.material}, R_m {process.tensile_strength_mpa:g} MPa, {1e3 * process.thickness_m:g} mm) "
             "is recorded but does not change them")
    return replace(process, force_model=chosen)


def spec_for_run(run: Run, spec: TwinSpec | None = None) -> TwinSpec:
    """`spec` (None: the run's robot in its cell) at the run's placement, checked to be of the run's robot.

    Raises:
        InputError: The spec is of another robot than the run was made with.
    """
    robot = resolve_robot(None if spec is None else spec.robot, None, run, label="the twin")
    return (spec or TwinSpec(robot=robot)).replace(placement=run_placement(run.meta))


def _differs_from_history(process: Process) -> bool:
    """Whether the process's sheet is not the thesis's, whose forces the shipped FE history holds."""
    default = Process()
    return process.history is None and (
        process.tensile_strength_mpa != default.tensile_strength_mpa or process.thickness_m != default.thickness_m
    )
