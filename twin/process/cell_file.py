"""A user's cell, declared once: the robot, its tool, where the sheet lies and the process (`--cell CELL.toml`).

    format = "tx200-twin-cell/1"
    name = "kr210-cell"                 # optional: the cell's name, as programs and runs record it
    robot = "kr210"                     # a shipped robot (`tx200-twin robots`) or a robot description file,
                                        # relative to this file
    [tool]                              # the tool on the flange (its tip along the flange z axis)
    length_mm = 250.0                   # flange to tool tip [mm]
    radius_mm = 5.0                     # the forming tool's tip radius [mm] (the process's tool radius)
    mass_kg = 3.5                       # the tool's mass, F/T sensor included [kg]
    cog_mm = [0.0, 0.0, 110.0]          # its centre of gravity in the flange frame [mm]
    diameter_mm = 25.0                  # its shank's diameter [mm]: the tool bends as a cantilever clamped at the
    youngs_modulus_gpa = 210.0          # flange, k = 3EI/L³ at the tip; E [GPa] defaults to steel's 210
    # bending_stiffness_n_per_mm = 450.0  # or its bending stiffness measured at the tip [N/mm] (not both)
    [ft_sensor]                         # the F/T sensor's mounting on the flange
    rotation_deg = 0.0                  # its axes turned about the flange z [deg] (or rpy_deg = [r, p, y]:
                                        # R = Rz(y) Ry(p) Rx(r), the sensor axes in the flange frame)
    offset_mm = [0.0, 0.0, 30.0]        # its measuring origin from the flange [mm] (moves torques only)
    [sheet]                             # the sheet frame in the robot base
    origin_mm = [1600.0, 0.0, 450.0]    # its origin [mm]
    yaw_deg = 0.0                       # its turn about the base z axis [deg]
    [process]                           # a process file's keys (`twin.process.process_file`), format aside
    material = "AA5754-O"
    thickness_mm = 1.0
    [sensors]                           # the cell's measuring chain, as the quasi-static lab samples it
    tracker_rate_hz = 50.0              # the tracker's rate [Hz] and white noise per axis [mm]
    tracker_noise_mm = 0.02
    ft_rate_hz = 30.0                   # the F/T sensor's rate [Hz] and white noise per axis [N]
    ft_noise_n = 5.0
    [controller]                        # the robot controller's slots and the online correction's limits
    tool_number = 16                    # the tool and load slot programs write and select (KRL TOOL_DATA[n], 1..16)
    base_number = 16                    # the base slot, the sheet frame (KRL BASE_DATA[n], 1..32)
    max_correction_mm = 8.0             # the online correction's size limit [mm] (program, compensator, server)
    max_rate_mm_s = 20.0                # its rate limit [mm/s] (the compensator's and the server's)

Every key but `format` may be left out: it keeps what the command would take without the cell (the robot's own
tool and sheet origin, the thesis's process). A command's own flags override the cell (`--robot`, `--origin-mm`,
`--yaw-deg`, `--material`, `--thickness-mm`, `--tool-radius-mm`, `--process`, `--tool-length-mm`,
`--tool-mass-kg`, `--tool-number`, `--base-number`, `--max-correction-mm`, `--max-rate-mm-s`; the online limits
are taken where there is an online correction): the cell is what a user would otherwise type on every command.
Without a bending key the tool is rigid (`twin.robot.tool_bending`); without `[ft_sensor]` an import takes the
sensor's axes as the sheet's (the mapping's default) unless its mapping says (`twin.robot.ft_mount`). Each value is
checked here, with the file and the key named: a length must be a number in its range (a tool of 15 m or a sheet
of 1 µm is no ISF cell).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twin.errors import DataFileError
from twin.process.description import PLAUSIBLE
from twin.process.material.file import read_toml
from twin.process.process_file import PROCESS_KEYS, ProcessDeclaration, declaration_from_table
from twin.robot.controller import ONLINE_LIMITS, SLOTS

CELL_FORMAT = "tx200-twin-cell/1"
CELL_KEYS = ("format", "name", "robot", "tool", "sheet", "process", "sensors", "ft_sensor", "controller")
#: The `[sensors]` keys and their ranges: rates of the trackers and F/T sensors cells use, noise up to ten times
#: the thesis's (its Krypton tracker 0.02 mm, its F/T 5 N in the twin's lab).
SENSOR_RANGES = {"tracker_rate_hz": (1.0, 2000.0, "Hz"), "ft_rate_hz": (1.0, 10000.0, "Hz"),
                 "tracker_noise_mm": (0.0, 1.0, "mm"), "ft_noise_n": (0.0, 200.0, "N")}
TOOL_KEYS = ("length_mm", "radius_mm", "mass_kg", "cog_mm", "diameter_mm", "youngs_modulus_gpa",
             "bending_stiffness_n_per_mm")
#: The tool's bending (`twin.robot.tool_bending`): a shank of Ø2 mm (a micro-ISF pin) to Ø150 mm; E of polymer
#: tools (~2 GPa) to cemented carbide (~620 GPa); a measured tip stiffness of a wobbly pin to a stub.
TOOL_DIAMETER_RANGE_MM = (2.0, 150.0)
YOUNGS_MODULUS_RANGE_GPA = (1.0, 1000.0)
BENDING_STIFFNESS_RANGE_N_PER_MM = (1.0, 1.0e7)
FT_SENSOR_KEYS = ("rotation_deg", "rpy_deg", "offset_mm")
SHEET_KEYS = ("origin_mm", "yaw_deg")
#: What a cell's tool may be: the process's plausible ranges (`twin.process.description.PLAUSIBLE`), one rule.
TOOL_LENGTH_RANGE_MM = (PLAUSIBLE["tool_length_m"].low, PLAUSIBLE["tool_length_m"].high)
TOOL_MASS_RANGE_KG = (PLAUSIBLE["tool_mass_kg"].low, PLAUSIBLE["tool_mass_kg"].high)
TOOL_RADIUS_RANGE_MM = (PLAUSIBLE["tool_radius_m"].low, PLAUSIBLE["tool_radius_m"].high)
#: How far a sheet origin may lie from the robot base [mm] (the largest industrial robots reach about 4 m).
ORIGIN_RANGE_MM = 5000.0


@dataclass(frozen=True)
class ToolDeclaration:
    """The cell's tool; None: not declared (the robot model's).

    Attributes:
        length_mm: Flange to tool tip [mm].
        mass_kg: Mass hanging at the flange [kg].
        cog_mm: Its centre of gravity in the flange frame [mm].
        diameter_mm: Its shank's diameter [mm] (its bending: a cantilever clamped at the flange).
        youngs_modulus_gpa: The shank's Young's modulus [GPa] (with a diameter; default steel's).
        bending_stiffness_n_per_mm: Its bending stiffness measured at the tip [N/mm] (instead of a diameter).
    """

    length_mm: float | None = None
    mass_kg: float | None = None
    cog_mm: tuple[float, float, float] | None = None
    diameter_mm: float | None = None
    youngs_modulus_gpa: float | None = None
    bending_stiffness_n_per_mm: float | None = None

    def bending(self) -> dict[str, float]:
        """The bending keys given, as the cell file has them (what runs and model files record)."""
        return {k: v for k, v in (("diameter_mm", self.diameter_mm), ("youngs_modulus_gpa", self.youngs_modulus_gpa),
                                  ("bending_stiffness_n_per_mm", self.bending_stiffness_n_per_mm)) if v is not None}


@dataclass(frozen=True)
class SensorMount:
    """The F/T sensor's mounting on the flange (`[ft_sensor]`).

    Attributes:
        rpy_deg: Its axes in the flange frame, R = Rz(yaw) Ry(pitch) Rx(roll) [deg].
        offset_mm: Its measuring origin from the flange, flange frame [mm].
    """

    rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class CellDeclaration:
    """A cell file (module docstring).

    Attributes:
        source: The file.
        name: The cell's name (default: the file's stem).
        robot: A shipped robot's name or a description file (absolute), or None.
        tool: The tool.
        origin_mm: The sheet origin in the robot base [mm], or None.
        yaw_deg: The sheet's yaw [deg], or None.
        process: What its `[process]` declares (the tool radius included).
        sensors: Its `[sensors]` values, by key (`SENSOR_RANGES`).
        ft_sensor: Its `[ft_sensor]` mounting; None: not declared (an import's sensor axes are the sheet's).
        controller: Its `[controller]` values, by key (`twin.robot.controller.SLOTS`, `ONLINE_LIMITS`).
    """

    source: Path
    name: str
    robot: str | None = None
    tool: ToolDeclaration = field(default_factory=ToolDeclaration)
    origin_mm: tuple[float, float, float] | None = None
    yaw_deg: float | None = None
    process: ProcessDeclaration = field(default_factory=ProcessDeclaration)
    sensors: Mapping[str, float] = field(default_factory=dict)
    ft_sensor: SensorMount | None = None
    controller: Mapping[str, float] = field(default_factory=dict)

    def record(self) -> dict[str, Any]:
        """What runs, model files and programs record of the cell (JSON-ready, millimetres as in the file)."""
        tool = {k: v for k, v in (("length_mm", self.tool.length_mm), ("mass_kg", self.tool.mass_kg),
                                  ("cog_mm", None if self.tool.cog_mm is None else list(self.tool.cog_mm)))
                if v is not None} | self.tool.bending()
        sheet = {k: v for k, v in (("origin_mm", None if self.origin_mm is None else list(self.origin_mm)),
                                   ("yaw_deg", self.yaw_deg)) if v is not None}
        return {"file": str(self.source.resolve()), "name": self.name, "robot": self.robot, "tool": tool, "sheet": sheet,
                "process": dict(self.process.origins), "sensors": dict(self.sensors),
                **({"controller": dict(self.controller)} if self.controller else {}),
                **({} if self.ft_sensor is None else {"ft_sensor": {"rpy_deg": list(self.ft_sensor.rpy_deg),
                                                                    "offset_mm": list(self.ft_sensor.offset_mm)}})}


def read_cell_file(path: str | Path) -> CellDeclaration:
    """Read and check a cell file (module docstring).

    Raises:
        DataFileError: Not a cell file, an unknown key, a value of the wrong kind or out of its range (naming the file
            and the key as written).
    """
    path = Path(path)
    data = read_toml(path)
    if data.get("format") != CELL_FORMAT:
        raise DataFileError(path, f"format = {data.get('format')!r}: expected {CELL_FORMAT!r}")
    _known(path, data, CELL_KEYS, "a cell file")
    name = data.get("name", path.stem)
    if not isinstance(name, str) or not name.strip():
        raise DataFileError(path, f"name = {name!r}: expected the cell's name")
    tool = _table(path, data, "tool")
    return CellDeclaration(path, name, _robot(path, data.get("robot")), _tool(path, tool),
                           *_sheet(path, _table(path, data, "sheet")),
                           _process(path, _table(path, data, "process"), tool.get("radius_mm")),
                           _sensors(path, _table(path, data, "sensors")),
                           _ft_sensor(path, data), _controller(path, _table(path, data, "controller")))


def _table(path: Path, data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    table = data.get(key, {})
    if not isinstance(table, Mapping):
        raise DataFileError(path, f"{key} = {table!r}: expected a table [{key}]")
    return table


def _known(path: Path, table: Mapping[str, Any], keys: tuple[str, ...], what: str, where: str = "") -> None:
    unknown = sorted(set(table) - set(keys))
    if unknown:
        raise DataFileError(path, f"unknown key(s) {[where + k for k in unknown]}; {what} takes {list(keys)}")


def _robot(path: Path, robot: Any) -> str | None:
    """A shipped robot's name as it is; a file (it has a suffix) relative to the cell file, which must exist."""
    if robot is None:
        return None
    if not isinstance(robot, str) or not robot.strip():
        raise DataFileError(path, f"robot = {robot!r}: expected a shipped robot's name or a description file")
    if Path(robot).suffix:
        file = Path(robot) if Path(robot).is_absolute() else path.parent / robot
        if not file.is_file():
            raise DataFileError(path, f"robot = {robot!r}: no such file {file}")
        return str(file.resolve())
    return robot


def _number(path: Path, key: str, value: Any, low: float, high: float, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise DataFileError(path, f"{key} = {value!r}: expected a number [{unit}]")
    if not low <= value <= high:
        raise DataFileError(path, f"{key} = {value!r}: expected {low:g} to {high:g} {unit} (an ISF cell's)")
    return float(value)


def _vector(path: Path, key: str, value: Any, bound: float) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise DataFileError(path, f"{key} = {value!r}: expected three numbers [mm]")
    x, y, z = (_number(path, key, v, -bound, bound, "mm") for v in value)
    return x, y, z


def _tool(path: Path, table: Mapping[str, Any]) -> ToolDeclaration:
    _known(path, table, TOOL_KEYS, "[tool]", "tool.")
    length = None if "length_mm" not in table else _number(path, "tool.length_mm", table["length_mm"],
                                                              *TOOL_LENGTH_RANGE_MM, "mm")
    mass = None if "mass_kg" not in table else _number(path, "tool.mass_kg", table["mass_kg"], *TOOL_MASS_RANGE_KG,
                                                       "kg")
    cog = None if "cog_mm" not in table else _vector(path, "tool.cog_mm", table["cog_mm"], TOOL_LENGTH_RANGE_MM[1])
    given = {key: _number(path, f"tool.{key}", table[key], *rng) for key, rng in (
        ("diameter_mm", (*TOOL_DIAMETER_RANGE_MM, "mm")), ("youngs_modulus_gpa", (*YOUNGS_MODULUS_RANGE_GPA, "GPa")),
        ("bending_stiffness_n_per_mm", (*BENDING_STIFFNESS_RANGE_N_PER_MM, "N/mm"))) if key in table}
    if "diameter_mm" in given and "bending_stiffness_n_per_mm" in given:
        raise DataFileError(path, "tool.diameter_mm and tool.bending_stiffness_n_per_mm both give the tool's bending; "
                            "keep one (the shank's diameter, or the stiffness measured at the tip)")
    if "youngs_modulus_gpa" in given and "diameter_mm" not in given:
        raise DataFileError(path, f"tool.youngs_modulus_gpa = {given['youngs_modulus_gpa']!r} without "
                            "tool.diameter_mm: the modulus bends a shank of a declared diameter")
    return ToolDeclaration(length, mass, cog, given.get("diameter_mm"), given.get("youngs_modulus_gpa"),
                           given.get("bending_stiffness_n_per_mm"))


def _ft_sensor(path: Path, data: Mapping[str, Any]) -> SensorMount | None:
    """The `[ft_sensor]` table: a turn about the flange z or a full rpy, and an offset."""
    if "ft_sensor" not in data:
        return None
    table = _table(path, data, "ft_sensor")
    _known(path, table, FT_SENSOR_KEYS, "[ft_sensor]", "ft_sensor.")
    if "rotation_deg" in table and "rpy_deg" in table:
        raise DataFileError(path, "ft_sensor.rotation_deg and ft_sensor.rpy_deg both turn the sensor; keep one")
    rpy = (0.0, 0.0, _number(path, "ft_sensor.rotation_deg", table.get("rotation_deg", 0.0), -360.0, 360.0, "deg"))
    if "rpy_deg" in table:
        value = table["rpy_deg"]
        if not isinstance(value, list) or len(value) != 3:
            raise DataFileError(path, f"ft_sensor.rpy_deg = {value!r}: expected three angles [deg]")
        r, p, y = (_number(path, "ft_sensor.rpy_deg", v, -360.0, 360.0, "deg") for v in value)
        rpy = (r, p, y)
    offset = (0.0, 0.0, 0.0) if "offset_mm" not in table else _vector(path, "ft_sensor.offset_mm", table["offset_mm"],
                                                                      TOOL_LENGTH_RANGE_MM[1])
    return SensorMount(rpy, offset)


def _sheet(path: Path, table: Mapping[str, Any]) -> tuple[tuple[float, float, float] | None, float | None]:
    _known(path, table, SHEET_KEYS, "[sheet]", "sheet.")
    origin = None if "origin_mm" not in table else _vector(path, "sheet.origin_mm", table["origin_mm"],
                                                           ORIGIN_RANGE_MM)
    yaw = None if "yaw_deg" not in table else _number(path, "sheet.yaw_deg", table["yaw_deg"], -360.0, 360.0, "deg")
    return origin, yaw


def _process(path: Path, table: Mapping[str, Any], radius_mm: Any) -> ProcessDeclaration:
    """The `[process]` table, with `[tool] radius_mm` as its tool radius (the tool's radius is the process's)."""
    keys = tuple(k for k in PROCESS_KEYS if k != "format")
    _known(path, table, keys, "[process]", "process.")
    declared = declaration_from_table(path, table, "process.")
    if radius_mm is None:
        return declared
    if "tool_radius_mm" in table:
        raise DataFileError(path, "tool.radius_mm and process.tool_radius_mm both give the tool's radius; keep one")
    radius = _number(path, "tool.radius_mm", radius_mm, *TOOL_RADIUS_RANGE_MM, "mm")
    return ProcessDeclaration(tool_radius_m=radius / 1e3,
                              origins=(("tool_radius_m", f"{path}: tool.radius_mm"),)).over(declared)


def _sensors(path: Path, table: Mapping[str, Any]) -> dict[str, float]:
    _known(path, table, tuple(SENSOR_RANGES), "[sensors]", "sensors.")
    return {key: _number(path, f"sensors.{key}", value, *SENSOR_RANGES[key]) for key, value in table.items()}


def _controller(path: Path, table: Mapping[str, Any]) -> dict[str, float]:
    """The `[controller]` table: the slots (whole numbers in their ranges) and the online limits (> 0)."""
    _known(path, table, (*SLOTS, *ONLINE_LIMITS), "[controller]", "controller.")
    out: dict[str, float] = {}
    for key, value in table.items():
        if key in SLOTS:
            slots = SLOTS[key]
            if isinstance(value, bool) or not isinstance(value, int) or value not in slots:
                raise DataFileError(path, f"controller.{key} = {value!r}: expected a whole number {slots.start} to "
                                    f"{slots.stop - 1} (the controller's slot)")
            out[key] = value
        else:
            high, unit = ONLINE_LIMITS[key]
            number = _number(path, f"controller.{key}", value, 0.0, high, unit)
            if number <= 0.0:
                raise DataFileError(path, f"controller.{key} = {value!r}: expected a number above 0 [{unit}]")
            out[key] = number
    return out
