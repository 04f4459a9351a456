"""`export`: a path CSV written as a robot program (Stäubli VAL3, KUKA KRL, ABB RAPID), G-code or a point list
(`twin.apps.export`). The robot is the request's, else the run's, else the default; the format its own language
unless the request names another (then a note); the tool length the request's, else the run's `meta.json`
`tool_length_m`, else the robot's; the tool mass the request's, else the run's import record
(`import.sensor.tool_mass_kg`), else the robot model's tool body. The report gives the process feed, the fastest
programmed move in contact and the arm configuration; the warnings (moves slowed to the process feed) are notes."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.resolve import resolve_robot
from twin.apps.export import (
    EXPORT_FORMATS,
    FORMATS,
    LANGUAGES,
    Exported,
    export_path,
    online_format,
    robot_format,
)
from twin.apps.export.program import default_cell
from twin.apps.tasks.base import Note, Report, silent
from twin.errors import InputError
from twin.process.description import check_plausible
from twin.process.toolpath.placement import Placement
from twin.robot.description import RobotDescription, load_robot
from twin.runs.format import Run, run_robot
from twin.runs.read import read_run


@dataclass(frozen=True)
class ExportRequest:
    """What to export.

    Attributes:
        path_csv: The path CSV t_s, x_mm, y_mm, z_mm (sheet frame).
        out: The program to write: VAL3 application folder, KRL .src (its .dat beside it), RAPID .mod, G-code or
            CSV file.
        format: A key of `FORMATS`; None: the robot's own language.
        robot: A robot name or description file; None: the run's, else the default robot.
        run: A run (tx200-twin-run/1) the program is for (its robot, tool length and tool mass), or None.
        tool_length_mm: Flange to tool tip along the flange z [mm]; None: the run's, else the robot's.
        tool_mass_kg: Tool mass for RAPID's tooldata [kg]; None: the run's imported sensor's, else the robot
            model's tool body's.
        safe_height_mm: Approach and retract height, sheet frame z [mm]; None: above the sheet and the path.
        feed_mm_s: The process feed [mm/s]; None: the median of the path's feeds.
        max_points: Points per file before a KRL or RAPID program is split; 0: the format's limit.
        online: The program with the twin's online correction switched on (KUKA: KRL with RSI and its Ethernet
            configuration, `twin.apps.export.krl_rsi`; ABB: RAPID with EGM path correction,
            `twin.apps.export.rapid_egm`; Stäubli: VAL3 `alter` moves, `twin.apps.export.val3_alter`), for
            `tx200-twin online --serve`.
        placement: The program's sheet frame in the robot base.
        cell: The `--cell` file's record (its tool and sheet are in the flags already), which the report names as
            where the tool and base came from, or None.
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
    placement: Placement = field(default_factory=Placement)
    online: bool = False
    cell: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.format is not None and self.format not in FORMATS:
            raise InputError(f"--format {self.format!r}: expected one of {', '.join(sorted(FORMATS))}")
        for option, value in (("--tool-length-mm", self.tool_length_mm), ("--tool-mass-kg", self.tool_mass_kg),
                              ("--feed-mm-s", self.feed_mm_s)):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise InputError(f"{option} {value:g}: expected a finite number > 0")
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
        if self.cell is not None:
            return f"the cell {self.cell['name']} ({self.cell['file']}) under the command's flags"
        return f"robot {self.robot.name}'s model and scene under the command's flags"

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


def export_task(request: ExportRequest, note: Note = silent) -> ExportReport:
    """Export the path as the request's program; a format not the robot's language and each warning are notes.

    Raises:
        InputError: A robot other than the run's, a bad path, a format the robot's language needs and no exporter
            writes (`twin.apps.export.export_path` lists the rest).
        UnreachableError, SingularityError: A point the robot cannot reach.
    """
    recorded = read_run(request.run, require_forces=False) if request.run is not None else None
    if recorded is not None and request.robot is not None:
        given, made = load_robot(request.robot), run_robot(recorded.meta, Path(request.run or ".") / "meta.json")
        if given.source != made.source:
            raise InputError(
                f"--robot gives robot {given.name!r}, but the run {request.run} was made with {made.name!r} (its "
                "tool_length_m is that robot's tool); expected the same robot, or leave out --robot or --run"
            )
    robot = resolve_robot(request.robot, None, recorded)
    fmt = request.format or (online_format(robot) if request.online else robot_format(robot))
    if request.online and not EXPORT_FORMATS[fmt].online:
        online = ", ".join(name for name, f in EXPORT_FORMATS.items() if f.online)
        raise InputError(f"--online with --format {fmt}: the online formats are {online}")
    if fmt in LANGUAGES and LANGUAGES[fmt] != robot.language:
        note(f"note: writing {LANGUAGES[fmt]} for robot {robot.name} ({robot.vendor} {robot.model}), whose "
             f"{robot.controller} runs {robot.language}: the program's configuration is {robot.name}'s IK solution")
    mass = request.tool_mass_kg if request.tool_mass_kg is not None else _run_tool_mass_kg(recorded)
    cell = default_cell(mass, request.placement, robot)
    if request.cell is not None and request.cell.get("tool", {}).get("cog_mm") is not None:
        cell = replace(cell, cog_mm=tuple(request.cell["tool"]["cog_mm"]))
    if request.tool_length_mm is not None:
        cell = replace(cell, tool_length_mm=request.tool_length_mm)
    elif recorded is not None:
        length_m = float(recorded.meta["tool_length_m"])
        check_plausible("tool_length_m", length_m, f"{Path(request.run or '.') / 'meta.json'}: tool_length_m "
                        f"{length_m:g} m")
        cell = replace(cell, tool_length_mm=1e3 * length_m)
    exported = export_path(request.path_csv, fmt, request.out, cell=cell, safe_z_mm=request.safe_height_mm,
                           process_feed_mm_s=request.feed_mm_s, max_points=request.max_points)
    for warning in exported.feeds.warnings():
        note(f"warning: {warning}")
    return ExportReport(request.path_csv, fmt, robot, exported, request.cell)


def _run_tool_mass_kg(recorded: Run | None) -> float | None:
    """The tool mass an imported run records (`import.sensor.tool_mass_kg`, the mass below the F/T sensor), if > 0."""
    if recorded is None:
        return None
    mass = recorded.meta.get("import", {}).get("sensor", {}).get("tool_mass_kg")
    return float(mass) if isinstance(mass, int | float) and mass > 0 else None
