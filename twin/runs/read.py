"""Reading and validating a `tx200-twin-run/1` run directory (`twin.runs.format`), and a commanded path alone.

Validation thresholds (the reader's contract): times strictly increasing, at least 2 rows per stream;
the commanded path starts at t_s = 0 (±1 ms); tracker and forces start within 1 s of it; meta rates
within 5 % of 1 / median sample interval; part_profile x strictly increasing. Units by declaration
(`twin.base.units`): every length column may be typed `_mm` (canonical) or `_m`, not both. Metres under
`_mm` names are refused by checks that do not depend on the part's size: a commanded path (and, when the
path moves, the tracker) whose median speed over the moving samples is below 0.05 mm/s; a part profile or
scan whose points all lie within 0.5 mm of the origin at a median neighbour step below 0.01 mm.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.csvio import check_monotonic
from twin.base.jsonio import read_json
from twin.base.units import SITable, check_path_speed, check_point_spacing, read_si_table
from twin.errors import DataFileError, InputError, RunFormatError, UnitsError
from twin.process.description import plausibility_problem
from twin.process.toolpath.groove import groove_path
from twin.runs.format import (
    CLOCK_TOLERANCE_S,
    FORCE_COLUMNS,
    POSITION_COLUMNS,
    PROFILE_COLUMNS,
    RATE_TOLERANCE,
    REQUIRED_META,
    RUN_FORMAT,
    RUN_FRAME,
    SCAN_COLUMNS,
    START_TOLERANCE_S,
    Run,
    Stream,
    frozen_array,
)


def _format_error(exc: DataFileError) -> RunFormatError:
    """Turn a plain DataFileError from csvio into a RunFormatError with the same file, row and text."""
    return RunFormatError(exc.path, exc.detail, exc.row)


def _check_meta(path: Path, meta: Mapping[str, Any], *, need_sensor_rate: bool) -> None:
    missing = [key for key in REQUIRED_META if key not in meta]
    if need_sensor_rate and "sensor_rate_hz" not in meta:
        missing.append("sensor_rate_hz")
    if missing:
        raise RunFormatError(
            path,
            f"missing key(s) {missing}; a {RUN_FORMAT} meta.json needs {list(REQUIRED_META)}"
            " and sensor_rate_hz when forces.csv is present",
        )
    if meta["format"] != RUN_FORMAT:
        raise RunFormatError(path, f"format is {meta['format']!r}, expected {RUN_FORMAT!r}")
    if meta["frame"] != RUN_FRAME:
        raise RunFormatError(
            path, f"frame is {meta['frame']!r}, expected {RUN_FRAME!r} (sheet frame, mm at the edges)"
        )
    if not isinstance(meta["scenario"], str):
        raise RunFormatError(path, f"scenario is {meta['scenario']!r}, expected a string")
    for key in ("tool_length_m", "tracker_rate_hz", "sensor_rate_hz"):
        if key not in meta:
            continue
        value = meta[key]
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not np.isfinite(value)
            or value <= 0
        ):
            raise RunFormatError(path, f"{key} is {value!r}, expected a positive number")
    if meta["tool_length_m"] > 5.0:
        raise UnitsError(
            path,
            f"tool_length_m is {meta['tool_length_m']!r}: is it in millimetres? expected metres "
            "(thesis tool: 0.27494)",
        )


def _read_table(path: Path, columns: Sequence[str], min_rows: int) -> SITable:
    """The file's columns in SI (lengths `_mm` or `_m`); a plain DataFileError becomes a RunFormatError."""
    try:
        return read_si_table(path, columns, min_rows=min_rows)
    except UnitsError:
        raise
    except DataFileError as exc:
        raise _format_error(exc) from None


def _read_stream(path: Path, columns: Sequence[str], *, check_speed: bool = False) -> Stream:
    """A timed stream in SI; with `check_speed`, refuse metres under `_mm` names (`check_path_speed`)."""
    table = _read_table(path, columns, 2)
    try:
        check_monotonic(path, columns[0], table.si(columns[0]))
    except DataFileError as exc:
        raise _format_error(exc) from None
    if check_speed:
        check_path_speed(table, columns[1:], time=columns[0])
    return Stream(table.si(columns[0]), np.column_stack([table.si(name) for name in columns[1:]]))


def _check_forces(path: Path, stream: Stream) -> None:
    """Refuse a force component outside its plausible range (`PLAUSIBLE["force_n"]`: a unit slip such as mN
    written as N), naming the file, the 1-based data row, the column and the value."""
    if not stream.values.size:
        return
    peak = np.abs(stream.values)
    row, column = np.unravel_index(int(np.argmax(peak)), peak.shape)
    name = FORCE_COLUMNS[1 + int(column)]
    problem = plausibility_problem("force_n", float(stream.values[row, column]), name)
    if problem:
        raise RunFormatError(path, problem, int(row) + 1)


def _check_rate(path: Path, stream: Stream, key: str, rate_hz: float) -> None:
    measured_hz = 1.0 / stream.median_interval_s
    if abs(measured_hz - rate_hz) > RATE_TOLERANCE * rate_hz:
        raise RunFormatError(
            path,
            f"median sample interval gives {measured_hz:.4g} Hz but meta.json {key} is {rate_hz:.4g} Hz "
            f"(more than {RATE_TOLERANCE:.0%} apart)",
        )


def _check_clock(path: Path, stream: Stream, start_s: float) -> None:
    if abs(stream.t_s[0] - start_s) > CLOCK_TOLERANCE_S:
        raise RunFormatError(
            path,
            f"starts at t_s = {stream.t_s[0]:.6g} s, {abs(stream.t_s[0] - start_s):.3g} s from the "
            f"commanded start {start_s:.6g} s (max {CLOCK_TOLERANCE_S:g} s): the streams must share a clock",
            1,
        )


def read_run(directory: str | Path, *, require_forces: bool = True) -> Run:
    """Read and validate a `tx200-twin-run/1` directory. Never opens truth.json.

    Args:
        directory: The run directory.
        require_forces: Raise when forces.csv is missing (otherwise `Run.forces` is None).

    Returns:
        The run, SI units.

    Raises:
        RunFormatError: Missing directory or file, wrong/missing columns, NaN, truncated or empty file,
            time not strictly increasing, wrong meta format/frame, rates that disagree with the samples,
            streams on different clocks. The message names the file and the 1-based data row.
        UnitsError: A length column spelled both `_mm` and `_m`, or metres written under `_mm` names (a
            moving path slower than 0.05 mm/s, profile or scan points packed within 0.5 mm; module docstring).
    """
    directory = Path(directory)
    if not directory.is_dir():
        raise RunFormatError(directory, f"run directory not found (expected a {RUN_FORMAT} directory)")
    files = {name: directory / name for name in ("meta.json", "commanded.csv", "tracker.csv", "forces.csv")}
    needed = ["meta.json", "commanded.csv", "tracker.csv"] + (["forces.csv"] if require_forces else [])
    for name in needed:
        if not files[name].is_file():
            raise RunFormatError(files[name], f"file not found; a {RUN_FORMAT} run needs {needed}")
    has_forces = files["forces.csv"].is_file()
    try:
        meta = read_json(files["meta.json"])
    except DataFileError as exc:
        raise _format_error(exc) from None
    _check_meta(files["meta.json"], meta, need_sensor_rate=has_forces)

    commanded = _read_stream(files["commanded.csv"], POSITION_COLUMNS, check_speed=True)
    if abs(commanded.t_s[0]) > START_TOLERANCE_S:
        raise RunFormatError(
            files["commanded.csv"],
            f"t_s starts at {commanded.t_s[0]:.6g} s, expected 0 "
            "(the shared clock starts with the commanded path)",
            1,
        )
    path_moves = bool(np.any(np.ptp(commanded.values, axis=0) > 0.0))  # a standing tracker shows only noise
    tracker = _read_stream(files["tracker.csv"], POSITION_COLUMNS, check_speed=path_moves)
    _check_rate(files["tracker.csv"], tracker, "tracker_rate_hz", float(meta["tracker_rate_hz"]))
    _check_clock(files["tracker.csv"], tracker, float(commanded.t_s[0]))

    forces = None
    if has_forces:
        forces = _read_stream(files["forces.csv"], FORCE_COLUMNS)
        _check_forces(files["forces.csv"], forces)
        _check_rate(files["forces.csv"], forces, "sensor_rate_hz", float(meta["sensor_rate_hz"]))
        _check_clock(files["forces.csv"], forces, float(commanded.t_s[0]))

    profile, scan = _read_part(directory)
    return Run(directory, dict(meta), commanded, tracker, forces, profile, scan)


def _read_part(directory: Path) -> tuple[tuple[np.ndarray, np.ndarray] | None, np.ndarray | None]:
    """The optional part profile (x, z) [m] and part scan (n, 3) [m] of a run directory (None where absent)."""
    profile = None
    profile_path = directory / "part_profile.csv"
    if profile_path.is_file():
        table = _read_table(profile_path, PROFILE_COLUMNS, 2)
        try:
            check_monotonic(profile_path, table.typed["x_mm"], table.si("x_mm"))
        except DataFileError as exc:
            raise _format_error(exc) from None
        check_point_spacing(table, PROFILE_COLUMNS)
        profile = (frozen_array(table.si("x_mm"), (), "x_m"), frozen_array(table.si("z_mm"), (), "z_m"))
    scan = None
    scan_path = directory / "part_scan.csv"
    if scan_path.is_file():
        table = _read_table(scan_path, SCAN_COLUMNS, 3)
        check_point_spacing(table, SCAN_COLUMNS)
        scan = frozen_array(np.column_stack([table.si(c) for c in SCAN_COLUMNS]), (3,), "part_scan_m")
    return profile, scan


def read_commanded_csv(path: str | Path) -> Stream:
    """Read a commanded tool path on its own (`commanded.csv` format, or `tx200-twin path` output).

    Args:
        path: CSV with columns `t_s, x_mm, y_mm, z_mm` (extra columns ignored), sheet frame; any length
            column may be declared in metres instead (`x_m`, ...).

    Returns:
        The path, SI units.

    Raises:
        RunFormatError: Missing file or columns, NaN, truncated rows, time not strictly increasing or not
            starting at 0.
        UnitsError: A length column spelled both ways, or metres under `_mm` names (a moving path slower
            than 0.05 mm/s, `twin.base.units.check_path_speed`).
    """
    path = Path(path)
    stream = _read_stream(path, POSITION_COLUMNS, check_speed=True)
    if abs(stream.t_s[0]) > START_TOLERANCE_S:
        raise RunFormatError(path, f"t_s starts at {stream.t_s[0]:.6g} s, expected 0", 1)
    return stream


def lab_commanded(scenario: str, commanded_csv: str | Path | None) -> tuple[Stream, list[Path]]:
    """The commanded path of a lab run: a `commanded.csv`-format file, else the thesis groove.

    Args:
        scenario: The lab scenario; `compensated` needs a file (a compensated path).
        commanded_csv: Path of the file, or None for the groove.

    Returns:
        The commanded path and the inputs a run written from it must never overwrite.

    Raises:
        InputError: `compensated` without a file.
    """
    if commanded_csv is None:
        if scenario == "compensated":
            raise InputError(
                "--scenario compensated needs --commanded PATH.csv (e.g. from `tx200-twin compensate`)"
            )
        path = groove_path()
        return Stream(path.t_s, path.p_sheet_m), []
    return read_commanded_csv(commanded_csv), [Path(commanded_csv)]
