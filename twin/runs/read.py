"""Reading and validating a `tx200-twin-run/1` run directory (`twin.runs.format`), and a commanded path alone.

Validation thresholds (the reader's contract): times strictly increasing, at least 2 rows per stream;
the commanded path starts at t_s = 0 (±1 ms); tracker and forces start within 1 s of it; meta rates
within 5 % of 1 / median sample interval; a commanded x span between 0 and 30 mm means metres were
written in `x_mm` (the groove is 70 mm long), as does a tracker x span below 0.5 mm while the path
moves; part_profile x strictly increasing and spanning at least 30 mm.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.csvio import check_mm_magnitude, check_monotonic, read_json, read_table
from twin.errors import DataFileError, InputError, RunFormatError, UnitsError
from twin.process.path import groove_path
from twin.runs.format import (
    CLOCK_TOLERANCE_S,
    FORCE_COLUMNS,
    MIN_PATH_SPAN_X_MM,
    MIN_SCAN_SPAN_MM,
    MIN_TRACKER_SPAN_X_MM,
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
    where = f"{exc.path}" if exc.row is None else f"{exc.path}, row {exc.row}"
    text = str(exc)
    message = text[len(where) + 2 :] if text.startswith(where + ": ") else text
    return RunFormatError(exc.path, message, exc.row)


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


def _read_stream(path: Path, columns: Sequence[str], scale: float) -> Stream:
    try:
        table = read_table(path, columns, min_rows=2)
        check_monotonic(path, "t_s", table["t_s"])
    except DataFileError as exc:
        raise _format_error(exc) from None
    values = np.column_stack([table[name] for name in columns[1:]]) * scale
    return Stream(table["t_s"], values)


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
        UnitsError: Metres written in a `_mm` column.
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

    commanded = _read_stream(files["commanded.csv"], POSITION_COLUMNS, 1e-3)
    if abs(commanded.t_s[0]) > START_TOLERANCE_S:
        raise RunFormatError(
            files["commanded.csv"],
            f"t_s starts at {commanded.t_s[0]:.6g} s, expected 0 "
            "(the shared clock starts with the commanded path)",
            1,
        )
    path_span_mm = float(np.ptp(commanded.values[:, 0])) * 1e3
    check_mm_magnitude(
        files["commanded.csv"], "x_mm", commanded.values[:, 0] * 1e3, min_span_mm=MIN_PATH_SPAN_X_MM
    )

    tracker = _read_stream(files["tracker.csv"], POSITION_COLUMNS, 1e-3)
    if path_span_mm >= MIN_PATH_SPAN_X_MM:
        check_mm_magnitude(
            files["tracker.csv"], "x_mm", tracker.values[:, 0] * 1e3, min_span_mm=MIN_TRACKER_SPAN_X_MM
        )
    _check_rate(files["tracker.csv"], tracker, "tracker_rate_hz", float(meta["tracker_rate_hz"]))
    _check_clock(files["tracker.csv"], tracker, float(commanded.t_s[0]))

    forces = None
    if has_forces:
        forces = _read_stream(files["forces.csv"], FORCE_COLUMNS, 1.0)
        _check_rate(files["forces.csv"], forces, "sensor_rate_hz", float(meta["sensor_rate_hz"]))
        _check_clock(files["forces.csv"], forces, float(commanded.t_s[0]))

    profile = None
    profile_path = directory / "part_profile.csv"
    if profile_path.is_file():
        try:
            table = read_table(profile_path, PROFILE_COLUMNS, min_rows=2)
            check_monotonic(profile_path, "x_mm", table["x_mm"])
        except DataFileError as exc:
            raise _format_error(exc) from None
        check_mm_magnitude(profile_path, "x_mm", table["x_mm"], min_span_mm=MIN_PATH_SPAN_X_MM)
        profile = (
            frozen_array(table["x_mm"] * 1e-3, (), "x_m"),
            frozen_array(table["z_mm"] * 1e-3, (), "z_m"),
        )
    scan = None
    scan_path = directory / "part_scan.csv"
    if scan_path.is_file():
        try:
            table = read_table(scan_path, SCAN_COLUMNS, min_rows=3)
        except DataFileError as exc:
            raise _format_error(exc) from None
        check_mm_magnitude(scan_path, "x_mm", table["x_mm"], min_span_mm=MIN_SCAN_SPAN_MM)
        scan = frozen_array(np.column_stack([table[c] for c in SCAN_COLUMNS]) * 1e-3, (3,), "part_scan_m")
    return Run(directory, dict(meta), commanded, tracker, forces, profile, scan)


def read_commanded_csv(path: str | Path) -> Stream:
    """Read a commanded tool path on its own (`commanded.csv` format, or `tx200-twin path` output).

    Args:
        path: CSV with columns `t_s, x_mm, y_mm, z_mm` (extra columns ignored), sheet frame.

    Returns:
        The path, SI units.

    Raises:
        RunFormatError: Missing file or columns, NaN, truncated rows, time not strictly increasing or not
            starting at 0. UnitsError: metres in the `_mm` columns.
    """
    path = Path(path)
    stream = _read_stream(path, POSITION_COLUMNS, 1e-3)
    if abs(stream.t_s[0]) > START_TOLERANCE_S:
        raise RunFormatError(path, f"t_s starts at {stream.t_s[0]:.6g} s, expected 0", 1)
    check_mm_magnitude(path, "x_mm", stream.values[:, 0] * 1e3, min_span_mm=MIN_PATH_SPAN_X_MM)
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
