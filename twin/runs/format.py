"""The run directory `tx200-twin-run/1`: one forming run (commanded path, tracker, forces), read and written.

A run is a directory holding:

- `meta.json`: `{"format": "tx200-twin-run/1", "frame": "sheet", "scenario": str, "tool_length_m": float,
  "tracker_rate_hz": float, "sensor_rate_hz": float, ...}` plus free keys (`"notes"`, ...). `sensor_rate_hz`
  is required only when `forces.csv` is present. Never the lab's hidden truth.
- `commanded.csv`: `t_s, x_mm, y_mm, z_mm`: the tool-tip path sent to the robot, sheet frame.
- `tracker.csv`: `t_s, x_mm, y_mm, z_mm`: the measured tool tip, sheet frame, at the tracker rate.
- `forces.csv`: `t_s, fx_n, fy_n, fz_n`: force exerted BY THE SHEET ON THE TOOL, sheet frame (Fz > 0 while
  forming), tool weight removed, at the sensor rate.
- optional `part_profile.csv`: `x_mm, z_mm`: the formed groove's centre line after unclamping (x increasing).
- optional `truth.json`: written by the lab for made-up runs; `read_run` never opens it.

All streams share one clock: `t_s = 0` at the start of the commanded path. Extra columns are ignored.
Inside the code everything is SI (m, N, s).

Validation thresholds (the reader's contract): times strictly increasing, at least 2 rows per stream;
the commanded path starts at t_s = 0 (±1 ms); tracker and forces start within 1 s of it; meta rates
within 5 % of 1 / median sample interval; a commanded x span between 0 and 30 mm means metres were
written in `x_mm` (the groove is 70 mm long), as does a tracker x span below 0.5 mm while the path
moves; part_profile x strictly increasing and spanning at least 30 mm.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.csvio import (
    check_mm_magnitude,
    check_monotonic,
    read_json,
    read_table,
    write_json,
    write_table,
)
from twin.base.signals import interp_rows
from twin.errors import DataFileError, InputError, RunFormatError, UnitsError

RUN_FORMAT = "tx200-twin-run/1"
RUN_FRAME = "sheet"
POSITION_COLUMNS = ("t_s", "x_mm", "y_mm", "z_mm")
FORCE_COLUMNS = ("t_s", "fx_n", "fy_n", "fz_n")
PROFILE_COLUMNS = ("x_mm", "z_mm")
REQUIRED_META = ("format", "frame", "scenario", "tool_length_m", "tracker_rate_hz")
MIN_PATH_SPAN_X_MM = 30.0  # the groove is 70 mm long (thesis §1.2): a commanded x span below this is metres
MIN_TRACKER_SPAN_X_MM = 0.5  # tracker x span below this while the path moves >= 30 mm: metres
RATE_TOLERANCE = 0.05  # meta rates may differ from the median sample interval by 5 %
CLOCK_TOLERANCE_S = 1.0  # a stream starting further than this from the commanded start has another clock
START_TOLERANCE_S = 1e-3  # the commanded path starts at t_s = 0


def _frozen_array(values: Any, shape_tail: tuple[int, ...], name: str) -> np.ndarray:
    array = np.array(values, dtype=float)
    if array.ndim != 1 + len(shape_tail) or array.shape[1:] != shape_tail:
        raise InputError(
            f"{name} has shape {array.shape}, expected (n, {', '.join(map(str, shape_tail))})"
            if shape_tail
            else f"{name} has shape {array.shape}, expected (n,)"
        )
    if not np.all(np.isfinite(array)):
        raise InputError(f"{name} holds NaN or inf; expected finite values")
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class Stream:
    """A sampled 3-vector signal.

    Attributes:
        t_s: Sample times, strictly increasing, shape (n,) [s].
        values: Samples, shape (n, 3): positions [m] or forces [N].
    """

    t_s: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        t_s = _frozen_array(self.t_s, (), "Stream.t_s")
        values = _frozen_array(self.values, (3,), "Stream.values")
        if values.shape[0] != t_s.shape[0]:
            raise InputError(f"Stream has {t_s.shape[0]} times but {values.shape[0]} samples; expected equal")
        if t_s.size >= 2 and np.any(np.diff(t_s) <= 0):
            raise InputError("Stream.t_s must be strictly increasing")
        object.__setattr__(self, "t_s", t_s)
        object.__setattr__(self, "values", values)

    @property
    def median_interval_s(self) -> float:
        """Median sample interval [s] (NaN for fewer than two samples)."""
        return float(np.median(np.diff(self.t_s))) if self.t_s.size >= 2 else float("nan")


@dataclass(frozen=True)
class Run:
    """One forming run, SI units, sheet frame.

    Attributes:
        directory: Where it was read from (None for a run made in memory).
        meta: Contents of meta.json (format, frame, scenario, tool_length_m, rates, free keys).
        commanded: Commanded tool-tip path [m].
        tracker: Measured tool tip [m].
        forces: Force of the sheet on the tool [N], or None.
        part_profile: (x_m, z_m) centre line of the formed groove [m], or None.
    """

    directory: Path | None
    meta: dict[str, Any]
    commanded: Stream
    tracker: Stream
    forces: Stream | None = None
    part_profile: tuple[np.ndarray, np.ndarray] | None = field(default=None)

    def __post_init__(self) -> None:
        if self.part_profile is not None:
            x_m, z_m = (np.asarray(a, dtype=float) for a in self.part_profile)
            if x_m.ndim != 1 or x_m.shape != z_m.shape:
                raise InputError(
                    f"part_profile x {x_m.shape} and z {z_m.shape} must be equal-length 1-D arrays"
                )

    @property
    def scenario(self) -> str:
        """Scenario name from meta.json."""
        return str(self.meta.get("scenario", ""))

    @property
    def tracker_rate_hz(self) -> float:
        """Tracker sampling rate from meta.json [Hz]."""
        return float(self.meta["tracker_rate_hz"])

    @property
    def sensor_rate_hz(self) -> float | None:
        """Force-sensor sampling rate from meta.json [Hz], None when absent."""
        rate = self.meta.get("sensor_rate_hz")
        return None if rate is None else float(rate)


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
            _frozen_array(table["x_mm"] * 1e-3, (), "x_m"),
            _frozen_array(table["z_mm"] * 1e-3, (), "z_m"),
        )
    return Run(directory, dict(meta), commanded, tracker, forces, profile)


def _protected_by(target: Path, protect: Sequence[str | Path]) -> Path | None:
    for other in protect:
        other_path = Path(other).resolve()
        if other_path == target or other_path.is_relative_to(target):
            return Path(other)
    return None


def write_run(
    directory: str | Path,
    run: Run,
    *,
    truth: Mapping[str, Any] | None = None,
    overwrite: bool = False,
    protect: Sequence[str | Path] = (),
) -> Path:
    """Write a run directory atomically (temporary sibling directory, validated, then renamed into place).

    Positions are written in mm with 4 decimals, forces in N with 3, times in s with 6. The written
    directory is read back with `read_run` before it replaces anything, so the writer never produces a
    run the reader rejects.

    Args:
        directory: Target run directory.
        run: The run (SI units). Missing `format`/`frame` keys in `run.meta` are filled in.
        truth: Lab-only hidden truth, written to truth.json when given.
        overwrite: Replace an existing non-empty directory.
        protect: Input paths that must not be inside (or be) the target; `run.directory` is always protected.

    Returns:
        The directory written.

    Raises:
        InputError: Target exists and is non-empty without `overwrite`, target holds a protected input,
            or the run does not satisfy the format (message names the file and row).
    """
    target = Path(directory).resolve()
    guarded = [*protect, *([run.directory] if run.directory is not None else [])]
    hit = _protected_by(target, guarded)
    if hit is not None:
        raise InputError(
            f"refusing to write run into {target}: it holds the input {hit}; choose another directory"
        )
    if target.exists() and not target.is_dir():
        raise InputError(f"{target} exists and is not a directory; choose another run directory")
    if target.exists() and any(target.iterdir()) and not overwrite:
        raise InputError(f"{target} exists and is not empty; pass overwrite=True or choose another directory")
    meta = {"format": RUN_FORMAT, "frame": RUN_FRAME, **run.meta}
    if "truth" in meta:
        raise InputError(
            "meta must not hold 'truth': pass it as write_run(..., truth=...) (written to truth.json)"
        )
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        write_json(tmp / "meta.json", meta)
        for name, stream in (("commanded.csv", run.commanded), ("tracker.csv", run.tracker)):
            mm = stream.values * 1e3
            write_table(
                tmp / name,
                {"t_s": stream.t_s, "x_mm": mm[:, 0], "y_mm": mm[:, 1], "z_mm": mm[:, 2]},
                formats={"t_s": ".6f", "x_mm": ".4f", "y_mm": ".4f", "z_mm": ".4f"},
            )
        if run.forces is not None:
            f = run.forces.values
            write_table(
                tmp / "forces.csv",
                {"t_s": run.forces.t_s, "fx_n": f[:, 0], "fy_n": f[:, 1], "fz_n": f[:, 2]},
                formats={"t_s": ".6f", "fx_n": ".3f", "fy_n": ".3f", "fz_n": ".3f"},
            )
        if run.part_profile is not None:
            x_m, z_m = run.part_profile
            write_table(
                tmp / "part_profile.csv",
                {"x_mm": np.asarray(x_m) * 1e3, "z_mm": np.asarray(z_m) * 1e3},
                formats={"x_mm": ".4f", "z_mm": ".4f"},
            )
        if truth is not None:
            write_json(tmp / "truth.json", truth)
        try:
            read_run(tmp, require_forces=run.forces is not None)
        except DataFileError as exc:
            raise InputError(
                f"run does not satisfy {RUN_FORMAT}: {str(exc).replace(str(tmp) + os.sep, '')}"
            ) from None
        if target.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".old", dir=target.parent))
            os.replace(target, old / "run")
            os.replace(tmp, target)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return target


def resample(stream: Stream, t_s: np.ndarray) -> np.ndarray:
    """Linearly interpolate a stream onto other times.

    Times within half a median sample interval outside the stream's range take the end value; further out
    is an error (no extrapolation).

    Args:
        stream: The stream.
        t_s: Query times, shape (m,) [s].

    Returns:
        Interpolated values, shape (m, 3), same units as `stream.values`.

    Raises:
        InputError: Query times are not finite or fall outside the range by more than half a sample.
    """
    query = np.asarray(t_s, dtype=float)
    if query.ndim != 1 or not np.all(np.isfinite(query)):
        raise InputError(f"t_s must be a finite 1-D array, got shape {query.shape}")
    if stream.t_s.size < 2:
        raise InputError(f"cannot interpolate a stream of {stream.t_s.size} sample(s); need at least 2")
    margin = 0.5 * stream.median_interval_s
    lo, hi = stream.t_s[0] - margin, stream.t_s[-1] + margin
    if query.size and (query.min() < lo or query.max() > hi):
        raise InputError(
            f"query times span [{query.min():.6g}, {query.max():.6g}] s, outside the stream's "
            f"[{stream.t_s[0]:.6g}, {stream.t_s[-1]:.6g}] s by more than half a sample ({margin:.3g} s)"
        )
    return interp_rows(query, stream.t_s, stream.values)


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
