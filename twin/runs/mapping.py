"""The import mapping: a TOML file that describes a cell's raw exports (schema: docs/import-export.md).

Read with the standard library's `tomllib`; every problem raises a `MappingError` that names the mapping
file, the line of the offending key and what was expected. Relative file names are relative to the
mapping file's folder. Units and frames are converted to SI here, so `twin.runs.importer` only sees
metres, newtons and seconds.
"""

from __future__ import annotations

import codecs
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.csvio import read_text
from twin.base.jsonio import NonFiniteNumberError, finite_float, non_finite_key, non_finite_message
from twin.errors import ModelError
from twin.process.description import plausibility_problem
from twin.robot.description import load_robot
from twin.runs.mapping_frame import LENGTH_UNITS
from twin.runs.mapping_frame import registration as _registration
from twin.runs.mapping_frame import rotation as _rotation
from twin.runs.registration import Registration
from twin.runs.toml_keys import ClockError, MappingError, TomlReader, key_line

FORCE_UNITS = {"N": 1.0, "kN": 1e3}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "µs": 1e-6, "us": 1e-6}
DELIMITERS = {",": ",", ";": ";", "tab": "\t", "\t": "\t"}
DECIMALS = (".", ",")
CLOCK_METHODS = ("offset", "force_onset", "motion_onset")
STANDARD_GRAVITY_M_S2 = 9.80665


@dataclass(frozen=True)
class TableSpec:
    """How to read one raw export.

    Attributes:
        name: Stream name (`commanded`, `tracker`, `forces`, `profile`).
        file: The raw file.
        delimiter: Field separator (`,`, `;` or a tab).
        decimal: Decimal separator (`.` or `,`).
        header_line: 1-based line of the header row, 0 when there is none.
        columns: Value columns, by header name or 0-based index (x, y, z / fx, fy, fz / x, z).
        scale: Factor from the file's unit to SI [m or N per file unit].
        time_column: Time column by name or index, None with `rate_hz` or for the profile.
        time_scale: Factor from the time unit to seconds [s per unit].
        rate_hz: Sample rate when the file has no time column [Hz].
        encoding: The file's text encoding (`encoding` key; default UTF-8, a BOM dropped).
    """

    name: str
    file: Path
    delimiter: str
    decimal: str
    header_line: int
    columns: tuple[str | int, ...]
    scale: float
    time_column: str | int | None
    time_scale: float
    rate_hz: float | None
    encoding: str = "utf-8-sig"


@dataclass(frozen=True)
class ClockSpec:
    """Clock of a stream: `t_shared = t_stream - offset_s`, or the offset found by `method`.

    Attributes:
        method: `offset`, `force_onset` or `motion_onset`.
        offset_s: The stream clock's reading when the commanded path starts [s] (method `offset`).
        max_offset_s: Largest offset a search may return [s].
    """

    method: str
    offset_s: float | None
    max_offset_s: float


@dataclass(frozen=True)
class SensorSpec:
    """Force sensor frame and the tool hanging below it.

    Attributes:
        R_sheet_sensor: Rotation of the sensor axes in the sheet frame (constant: the ISF tool stays vertical).
        tool_mass_kg: Mass below the sensor's measuring plane [kg].
        com_sensor_m: Its centre of mass in the sensor frame [m] (enters torques only; recorded in meta).
        gravity_sheet_m_s2: Gravity in the sheet frame [m/s^2].
    """

    R_sheet_sensor: np.ndarray
    tool_mass_kg: float
    com_sensor_m: np.ndarray
    gravity_sheet_m_s2: np.ndarray


@dataclass(frozen=True)
class ImportMapping:
    """A validated import mapping, SI units.

    Attributes:
        path: The mapping file.
        scenario: Scenario label for meta.json.
        tool_length_m: Tool length for meta.json [m].
        notes: Free text for meta.json.
        commanded, tracker, forces, profile: How to read each raw export (profile optional).
        registration: Tracker-to-sheet transform, given or fitted to reference points (with its residual).
        tracker_clock, forces_clock: Clock alignment of the two measured streams.
        sensor: Force sensor frame and tool weight.
        robot: `run.robot`: a shipped robot's name or a description file (absolute), or None.
        placement: `run.origin_mm` / `run.yaw_deg` [mm, deg] as written: {"origin_mm": [x, y, z] or None,
            "yaw_deg": number or None}.
        tool_length_given: Whether `run.tool_length_mm` was written (else `tool_length_m` is the robot's).
        sensor_rotation_given: Whether `forces.sensor.R_sheet_sensor` was written (else a cell's `[ft_sensor]`
            mount gives it, `twin.runs.importer.with_cell`, else the sheet's axes).
    """

    path: Path
    scenario: str
    tool_length_m: float
    notes: str
    commanded: TableSpec
    tracker: TableSpec
    forces: TableSpec
    profile: TableSpec | None
    registration: Registration
    tracker_clock: ClockSpec
    forces_clock: ClockSpec
    sensor: SensorSpec
    robot: str | None = None
    placement: dict[str, Any] = field(default_factory=dict)
    tool_length_given: bool = False
    sensor_rotation_given: bool = False

    def inputs(self) -> list[Path]:
        """Every file the mapping reads (never to be written over)."""
        tables = [self.commanded, self.tracker, self.forces, *([self.profile] if self.profile else [])]
        return [self.path, *(t.file for t in tables)]


def _table(reader: TomlReader, name: str, columns: tuple[str, ...], units: dict[str, float]) -> TableSpec:
    file_text = reader.get(f"{name}.file", kind=str)
    file = (reader.path.parent / file_text).resolve()
    if not file.is_file():
        raise reader.error(f"{name}.file", f"file not found: {file}")
    delimiter = reader.get(f"{name}.delimiter", ",", kind=str)
    if delimiter not in DELIMITERS:
        raise reader.error(f"{name}.delimiter", f"is {delimiter!r}, expected one of ',', ';', 'tab'")
    decimal = reader.get(f"{name}.decimal", ".", kind=str)
    if decimal not in DECIMALS:
        raise reader.error(f"{name}.decimal", f"is {decimal!r}, expected '.' or ','")
    if decimal == DELIMITERS[delimiter]:
        raise reader.error(f"{name}.decimal", f"decimal separator {decimal!r} equals the delimiter")
    header_line = reader.get(f"{name}.header_line", 1, kind=int)
    if header_line < 0:
        raise reader.error(
            f"{name}.header_line", f"is {header_line}, expected 0 (no header) or a line number"
        )
    cols: list[str | int] = []
    for column in columns:
        value = reader.get(f"{name}.{column}", kind=(str, int))
        if (isinstance(value, int) and value < 0) or (isinstance(value, str) and header_line == 0):
            raise reader.error(
                f"{name}.{column}", f"is {value!r}, expected a 0-based column index (or a name with a header)"
            )
        cols.append(value)
    scale = reader.unit(f"{name}.unit", units)
    time_column = reader.get(f"{name}.time", None, kind=(str, int))
    rate = reader.number(f"{name}.rate_hz", None, positive=True)
    if name != "profile" and (time_column is None) == math.isnan(rate):
        raise reader.error(f"{name}.time", "give either a time column ('time' with 'time_unit') or 'rate_hz'")
    time_scale = reader.unit(f"{name}.time_unit", TIME_UNITS, "s")
    encoding = reader.get(f"{name}.encoding", "utf-8-sig", kind=str)
    try:
        codecs.lookup(encoding)
    except LookupError:
        raise reader.error(f"{name}.encoding", f"is {encoding!r}, expected an encoding such as 'utf-8' or "
                                               "'latin-1'") from None
    return TableSpec(
        name,
        file,
        DELIMITERS[delimiter],
        decimal,
        header_line,
        tuple(cols),
        scale,
        time_column,
        time_scale,
        None if math.isnan(rate) else rate,
        encoding,
    )


def _clock(reader: TomlReader, name: str, default_method: str) -> ClockSpec:
    offset = reader.number(f"{name}.clock.offset_s", None)
    method = reader.get(
        f"{name}.clock.method", "offset" if not math.isnan(offset) else default_method, kind=str
    )
    if method not in CLOCK_METHODS:
        raise reader.error(f"{name}.clock.method", f"is {method!r}, expected one of {list(CLOCK_METHODS)}")
    if method == "offset" and math.isnan(offset):
        raise reader.error(f"{name}.clock.offset_s", "method 'offset' needs offset_s [s]", ClockError)
    max_offset = reader.number(f"{name}.clock.max_offset_s", 600.0, positive=True)
    return ClockSpec(method, None if math.isnan(offset) else offset, max_offset)


def mapping_keys() -> list[str]:
    """Every key an import mapping may hold, dotted (docs/import-export.md)."""
    table = ("file", "delimiter", "decimal", "header_line", "encoding", "unit", "time", "time_unit", "rate_hz")
    clock = ("clock.offset_s", "clock.method", "clock.max_offset_s")
    keys = [f"run.{k}" for k in ("scenario", "tool_length_mm", "notes", "robot", "origin_mm", "yaw_deg")]
    for name, columns in (("commanded", "xyz"), ("tracker", "xyz"), ("forces", ("fx", "fy", "fz")), ("profile", "xz")):
        keys += [f"{name}.{k}" for k in (*table, *columns)]
    keys += [f"{name}.{k}" for name in ("tracker", "forces") for k in clock]
    keys += [f"tracker.frame.{k}" for k in ("unit", "T_sheet_tracker", "points_sheet", "points_tracker")]
    keys += [f"forces.sensor.{k}" for k in ("R_sheet_sensor", "gravity_sheet_m_s2", "com_sensor_mm", "tool_mass_kg")]
    return keys


def load_mapping(path: str | Path) -> ImportMapping:
    """Read and validate an import mapping.

    Args:
        path: The TOML mapping file.

    Returns:
        The mapping, SI units, with absolute file names.

    Raises:
        MappingError: Missing mapping or raw file, bad TOML, missing key, unknown unit, bad value; names the
            mapping file, the line and the key. RegistrationError: fewer than 3 reference points or mismatched
            lists. ClockError: an `offset` clock without `offset_s`.
    """
    path = Path(path).resolve()
    if not path.is_file():
        raise MappingError(path, "mapping file not found")
    text = read_text(path, "an import mapping (TOML, UTF-8)")
    try:
        try:
            data = tomllib.loads(text, parse_float=finite_float)
        except NonFiniteNumberError as exc:  # find its key in the document read without the check
            key = non_finite_key(tomllib.loads(text))  # (a TOML error after the number is that error)
            dotted = None if key is None else key.split("[", 1)[0]
            raise MappingError(path, non_finite_message(key, exc.text), None if dotted is None else
                               key_line(text, dotted), dotted) from None
    except tomllib.TOMLDecodeError as exc:
        line = re.search(r"line (\d+)", str(exc))
        raise MappingError(path, f"not valid TOML ({exc})", int(line.group(1)) if line else None) from None
    r = TomlReader(path, text, data)
    r.check_keys(mapping_keys())
    registration = _registration(r)
    R_sensor = r.matrix("forces.sensor.R_sheet_sensor", (3, 3), [[1, 0, 0], [0, 1, 0], [0, 0, 1]])
    assert R_sensor is not None
    gravity = r.vector("forces.sensor.gravity_sheet_m_s2", [0.0, 0.0, -STANDARD_GRAVITY_M_S2])
    com = r.vector("forces.sensor.com_sensor_mm", [0.0, 0.0, 0.0])
    sensor = SensorSpec(
        _rotation(r, "forces.sensor.R_sheet_sensor", R_sensor),
        r.number("forces.sensor.tool_mass_kg", 0.0),
        com * 1e-3,
        gravity,
    )
    if sensor.tool_mass_kg < 0:
        raise r.error("forces.sensor.tool_mass_kg", f"is {sensor.tool_mass_kg}, expected >= 0 [kg]")
    problem = plausibility_problem("tool_mass_kg", sensor.tool_mass_kg, "forces.sensor.tool_mass_kg")
    if problem:
        raise r.error("forces.sensor.tool_mass_kg", problem)
    robot = _robot(r, path)
    tool_length_m = r.number("run.tool_length_mm", load_robot(robot).tool_length_m * 1e3, positive=True) * 1e-3
    problem = plausibility_problem("tool_length_m", tool_length_m, "run.tool_length_mm")
    if problem:
        raise r.error("run.tool_length_mm", problem)
    has_profile = isinstance(data.get("profile"), dict)
    return ImportMapping(
        path=path,
        scenario=r.get("run.scenario", "imported", kind=str),
        tool_length_m=tool_length_m,
        notes=r.get("run.notes", "", kind=str),
        commanded=_table(r, "commanded", ("x", "y", "z"), LENGTH_UNITS),
        tracker=_table(r, "tracker", ("x", "y", "z"), LENGTH_UNITS),
        forces=_table(r, "forces", ("fx", "fy", "fz"), FORCE_UNITS),
        profile=_table(r, "profile", ("x", "z"), LENGTH_UNITS) if has_profile else None,
        registration=registration,
        tracker_clock=_clock(r, "tracker", "offset"),
        forces_clock=_clock(r, "forces", "offset"),
        sensor=sensor,
        robot=robot,
        placement={"origin_mm": None if r.get("run.origin_mm", None) is None else r.vector("run.origin_mm").tolist(),
                   "yaw_deg": None if r.get("run.yaw_deg", None) is None else r.number("run.yaw_deg")},
        tool_length_given=r.get("run.tool_length_mm", None) is not None,
        sensor_rotation_given=r.get("forces.sensor.R_sheet_sensor", None) is not None,
    )


def _robot(r: TomlReader, path: Path) -> str | None:
    """`run.robot`: a shipped robot's name, or a description file relative to the mapping (made absolute)."""
    name = r.get("run.robot", None, kind=str)
    if name is None:
        return None
    if Path(name).suffix and not Path(name).is_absolute():
        name = str((path.parent / name).resolve())
    try:
        load_robot(name)
    except ModelError as exc:
        raise r.error("run.robot", f"is {name!r}: {exc}") from None
    return str(name)
