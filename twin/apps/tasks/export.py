"""`export`: a path CSV written as a robot program (Stäubli VAL3, KUKA KRL, ABB RAPID), G-code or a point list
(`twin.apps.export`). The robot, the sheet's placement and the tool follow one precedence, each value on its own
(`twin.analysis.resolve.PRECEDENCE`): an explicit flag > the run's record > the cell file > the robot's defaults
(a `--robot` or a cell naming another robot than the run's is refused). The format is the robot's own language
unless the request names another; a robot language not the robot's maker's is refused (G-code and the CSV point
list are open to every robot). The program's first comment lines state the sheet frame and the
tool it was written with and where each came from (`twin.apps.export.program.cell_lines`). The report gives the
process feed, the fastest programmed move in contact and the arm configuration; the warnings (moves slowed to the
process feed) are notes."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.resolve import resolve_placement, resolve_robot
from twin.analysis.tool_choice import resolve_tool
from twin.apps.export import (
    EXPORT_FORMATS,
    FORMATS,
    LANGUAGES,
    Exported,
    export_path,
    online_format,
    rapid_egm,
    rapid_egm_pose,
    robot_format,
)
from twin.apps.export.program import default_cell
from twin.apps.tasks.base import Note, Report, silent
from twin.errors import InputError
from twin.process.description import check_plausible
from twin.robot.controller import BASE_NUMBERS, DEFAULT_BASE_NUMBER, DEFAULT_TOOL_NUMBER, TOOL_NUMBERS
from twin.robot.description import load_robot
from twin.robot.facts import RobotDescription
from twin.runs.format import run_robot
from twin.runs.read import read_run
from twin.sim.online_settings import OnlineSettings, check_max_correction_mm


@dataclass(frozen=True)
class ExportRequest:
    """What to export.

    Attributes:
        path_csv: The path CSV t_s, x_mm, y_mm, z_mm (sheet frame).
        out: The program to write: VAL3 application folder, KRL .src (its .dat beside it), RAPID .mod, G-code or
            CSV file.
        format: A key of `FORMATS`; None: the robot's own language.
        robot: A robot name or description file, as typed; None: the run's, else the cell's, else the default.
        run: A run (tx200-twin-run/1) the program is for (its robot, placement, tool length and tool mass), or None.
        tool_length_mm: Flange to tool tip along the flange z [mm], as typed; None: the run's, else the cell's, else
            the robot's.
        tool_mass_kg: Tool mass for the program's load data [kg], as typed; None: the run's (its cell's tool, else
            its imported sensor's), else the cell's, else the robot model's tool body's.
        safe_height_mm: Approach and retract height, sheet frame z [mm]; None: above the sheet and the path.
        feed_mm_s: The process feed [mm/s]; None: the median of the path's feeds.
        max_points: Points per file before a KRL or RAPID program is split; 0: the format's limit.
        online: The program with the twin's online correction switched on (KUKA: KRL with RSI and its Ethernet
            configuration, `twin.apps.export.krl_rsi`; ABB: RAPID with EGM path correction,
            `twin.apps.export.rapid_egm`; Stäubli: VAL3 `alter` moves, `twin.apps.export.val3_alter`), for
            `tx200-twin online --serve`.
        origin_mm: The sheet origin in the robot base [mm] as typed (`--origin-mm`); None: the run's, else the
            cell's, else the robot's default sheet origin.
        yaw_deg: The sheet's yaw [deg] as typed (`--yaw-deg`, 0 included); None: the run's, else the cell's, else 0.
        cell: The `--cell` file's record (`CellDeclaration.record`: its robot, tool and sheet, under the typed
            values and the run's), or None.
        tool_number: The controller's tool (and load) slot a KRL program overwrites and uses (`--tool-number`,
            1..16); the default 16 leaves the cell's calibrated tool 1 alone.
        base_number: The controller's base slot a KRL program overwrites and uses (`--base-number`, 1..32); the
            default 16 leaves base 1 alone.
        egm_mode: ABB EGM's program (`--egm-mode`, `rapid_egm_pose.MODES`): "pose" (position guidance, the default
            of `--online`), "path" (path correction); None: the default, or what `--format` names.
        max_correction_mm: An online program's limit on the correction [mm] (`--max-correction-mm`): the one its
            server is given (`tx200-twin online --max-correction-mm`).
    """

    path_csv: Path
    out: Path
    format: str | None = None
    robot: str | Path | None = None
    run: Path | None = None
    tool_length_mm: float | None = None
    tool_mass_kg: float | None = None
    safe_height_mm: float | None = None
    feed_mm_s: float | None = None
    max_points: int = 0
    online: bool = False
    cell: Mapping[str, Any] | None = None
    origin_mm: tuple[float, float, float] | None = None
    yaw_deg: float | None = None
    tool_number: int = DEFAULT_TOOL_NUMBER
    base_number: int = DEFAULT_BASE_NUMBER
    egm_mode: str | None = None
    max_correction_mm: float = OnlineSettings.max_correction_mm

    def __post_init__(self) -> None:
        check_max_correction_mm(self.max_correction_mm, online=self.online)
        if self.format is not None and self.format not in FORMATS:
            raise InputError(f"--format {self.format!r}: expected one of {', '.join(sorted(FORMATS))}")
        for option, value in (("--tool-length-mm", self.tool_length_mm), ("--tool-mass-kg", self.tool_mass_kg),
                              ("--feed-mm-s", self.feed_mm_s)):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise InputError(f"{option} {value:g}: expected a finite number > 0")
        for option, number, slots in (("--tool-number", self.tool_number, TOOL_NUMBERS),
                                      ("--base-number", self.base_number, BASE_NUMBERS)):
            if isinstance(number, bool) or not isinstance(number, int) or number not in slots:
                raise InputError(f"{option} {number!r}: expected a whole number {slots.start}..{slots.stop - 1} "
                                 f"(KRL's {'TOOL_DATA' if option == '--tool-number' else 'BASE_DATA'}"
                                 f"[{slots.stop - 1}])")
        if self.tool_length_mm is not None:
            check_plausible("tool_length_m", self.tool_length_mm / 1e3, f"--tool-length-mm {self.tool_length_mm:g}")
        if self.tool_mass_kg is not None:
            check_plausible("tool_mass_kg", self.tool_mass_kg, f"--tool-mass-kg {self.tool_mass_kg:g}")


@dataclass(frozen=True)
class ExportReport(Report):
    """The program written.

    Attributes:
        path_csv: The path exported.
        format: The format written.
        robot: The robot the program is for.
        exported: The program, the files written and the feed summary.
    """

    path_csv: Path
    format: str
    robot: RobotDescription
    exported: Exported
    cell: Mapping[str, Any] | None = None

    @property
    def origin(self) -> str:
        """Where the program's tool and base came from."""
        sources = dict(self.exported.path.cell.sources or {})
        return (f"sheet origin: {sources.get('origin')}; yaw: {sources.get('yaw')}; tool length: "
                f"{sources.get('tool_length')}; tool mass: {sources.get('tool_mass')}")

    def lines(self) -> list[str]:
        path, files, feeds = self.exported
        config = path.cell.configuration
        configured = "" if config is None else f", configuration {config.text(LANGUAGES.get(self.format, ''))}"
        return [
            f"export {self.path_csv} -> {self.format} program {path.name} for {self.robot.name}: "
            f"{len(path.points_mm)} points (approach and retract at z = {feeds.safe_z_mm:.2f} mm), process feed "
            f"{feeds.process_mm_s:.2f} mm/s, max feed in contact {feeds.max_in_contact_mm_s:.2f} mm/s (path "
            f"{feeds.path_max_in_contact_mm_s:.2f}), tool {path.cell.tool_length_mm:.2f} mm "
            f"{path.cell.tool_mass_kg:.3g} kg{configured}; tool and base from {self.origin}; wrote "
            f"{', '.join(str(f) for f in files)}"
        ]

    def record(self) -> dict[str, Any]:
        path, files, feeds = self.exported
        feed, config = path.feed_mm_s, path.cell.configuration
        return {
            "format": self.format,
            "robot": path.cell.robot,
            "program": path.name,
            "points": len(path.points_mm),
            "files": [str(f) for f in files],
            "feed_mm_s": {
                "process": feeds.process_mm_s,
                "max_in_contact": feeds.max_in_contact_mm_s,
                "path_max_in_contact": feeds.path_max_in_contact_mm_s,
                "slowed_moves": feeds.slowed,
                "added_time_s": feeds.added_time_s,
                "min": float(np.min(feed)),
                "median": float(np.median(feed)),
                "max": float(np.max(feed)),
            },
            "safe_height_mm": feeds.safe_z_mm,
            "warnings": feeds.warnings(),
            "sheet_origin_in_base_mm": path.cell.p_base_sheet_mm.tolist(),
            "tool_length_mm": path.cell.tool_length_mm,
            "tool_mass_kg": path.cell.tool_mass_kg,
            "tool_and_base_from": self.origin,
            "cell": self.cell,
            "configuration": None if config is None else {
                "program": config.text(LANGUAGES.get(self.format, "")),
                "description": config.describe(),
                "axes_deg": list(config.axes_deg),
            },
        }


def foreign_language_problem(fmt: str, robot: RobotDescription) -> str:
    """Why `--format fmt` (a controller language) cannot be written for `robot`: its controller runs another (or
    none is declared). Names the format, the robot, its language, the formats open to every robot and, for a robot
    that declares no language the twin writes, what to declare."""
    language = LANGUAGES[fmt]
    open_formats = " or ".join(name for name, f in EXPORT_FORMATS.items() if f.language is None and not f.online)
    own = [name for name, f in EXPORT_FORMATS.items() if f.language == robot.language and not f.online]
    if own:
        expected = f"expected --format {' or '.join(own)} (its language) or {open_formats} (open to every robot)"
    else:
        expected = (f"expected --format {open_formats} (open to every robot), or a robot description (.toml, "
                    f"format tx200-twin-robot/1) that declares vendor and language = {language!r} for a "
                    f"{language} program")
    return (f"--format {fmt} writes {language}, but robot {robot.name!r} ({robot.vendor} {robot.model}, "
            f"{robot.controller}) runs {robot.language!r}: a program in another maker's language is refused; "
            f"{expected}")


def export_task(request: ExportRequest, note: Note = silent) -> ExportReport:
    """Export the path as the request's program; each warning is a note.

    Raises:
        InputError: A robot other than the run's, a bad path, a robot language not the robot's own
            (`foreign_language_problem`), a format the robot's language needs and no exporter writes
            (`twin.apps.export.export_path` lists the rest).
        UnreachableError, SingularityError: A point the robot cannot reach.
    """
    recorded = read_run(request.run, require_forces=False) if request.run is not None else None
    cell_robot = None if request.cell is None else request.cell.get("robot")
    if recorded is not None:
        made = run_robot(recorded.meta, Path(request.run or ".") / "meta.json")
        cell_given = cell_robot if request.robot is None else None  # a typed --robot overrides the cell's
        for what, name in (("--robot", request.robot), (f"the cell {(request.cell or {}).get('file')}", cell_given)):
            if name is not None and load_robot(name).source != made.source:
                raise InputError(
                    f"{what} gives robot {load_robot(name).name!r}, but the run {request.run} was made with "
                    f"{made.name!r} (its placement and tool are that robot's); expected the same robot, or leave out "
                    f"{'--robot' if what == '--robot' else '--cell'} or --run"
                )
    robot = resolve_robot(request.robot if request.robot is not None else None if recorded else cell_robot,
                          None, recorded)
    fmt = request.format or (online_format(robot) if request.online else robot_format(robot))
    fmt = rapid_egm_pose.egm_format(fmt, request.egm_mode, chosen=request.format is not None)
    if request.online and not EXPORT_FORMATS[fmt].online:
        online = ", ".join(name for name, f in EXPORT_FORMATS.items() if f.online)
        raise InputError(f"--online with --format {fmt}: the online formats are {online}")
    if fmt in LANGUAGES and LANGUAGES[fmt] != robot.language:
        raise InputError(foreign_language_problem(fmt, robot))
    place = resolve_placement(origin_mm=request.origin_mm, yaw_deg=request.yaw_deg, run=recorded, cell=request.cell,
                              robot_name=robot.name)
    tool = resolve_tool(robot, length_mm=request.tool_length_mm, mass_kg=request.tool_mass_kg, run=recorded,
                        cell=request.cell)
    cell = default_cell(tool.mass_kg, place.placement, robot)
    cell = replace(cell, tool_length_mm=tool.length_mm, sources={
        "origin": place.origin_from, "yaw": place.yaw_from, "tool_length": tool.length_from,
        "tool_mass": tool.mass_from})
    if request.cell is not None and request.cell.get("tool", {}).get("cog_mm") is not None:
        cell = replace(cell, cog_mm=tuple(request.cell["tool"]["cog_mm"]))
    exported = export_path(request.path_csv, fmt, request.out, cell=cell, safe_z_mm=request.safe_height_mm,
                           process_feed_mm_s=request.feed_mm_s, max_points=request.max_points,
                           tool_number=request.tool_number, base_number=request.base_number,
                           max_correction_mm=request.max_correction_mm)
    for warning in exported.feeds.warnings():
        note(f"warning: {warning}")
    if fmt == "rapid-egm":
        note(f"note: {rapid_egm.ALONG_PATH_NOTE}")
    elif fmt == "rapid-egm-pose":
        table = exported.files[0].with_name(f"{exported.path.name}_egm_pose.csv")
        note("note: " + rapid_egm_pose.NOTE.format(table=table))
    return ExportReport(request.path_csv, fmt, robot, exported, request.cell)
