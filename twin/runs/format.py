"""The run directory `tx200-twin-run/1`: one forming run (commanded path, tracker, forces), read and written.

A run is a directory holding:

- `meta.json`: `{"format": "tx200-twin-run/1", "frame": "sheet", "scenario": str, "tool_length_m": float,
  "tracker_rate_hz": float, "sensor_rate_hz": float, ...}` plus free keys (`"notes"`, ...). `sensor_rate_hz`
  is required only when `forces.csv` is present. Optional `robot` (its name), `force_model` (the sheet's force
  model, `twin.process.force.registry`), `process` (`{"material", "tensile_strength_mpa", "thickness_mm",
  "tool_radius_mm", "tool_friction"}`, `twin.process.process_file.process_record`; absent: the thesis's process)
  and `placement` (`twin.process.toolpath.placement.Placement.to_json`). Never the lab's hidden truth.
- `commanded.csv`: `t_s, x_mm, y_mm, z_mm`: the tool-tip path sent to the robot, sheet frame.
- `tracker.csv`: `t_s, x_mm, y_mm, z_mm`: the measured tool tip, sheet frame, at the tracker rate.
- `forces.csv`: `t_s, fx_n, fy_n, fz_n`: force exerted BY THE SHEET ON THE TOOL, sheet frame (Fz > 0 while
  forming), tool weight removed, at the sensor rate.
- optional `part_profile.csv`: `x_mm, z_mm`: the formed groove's centre line after unclamping (x increasing).
- optional `part_scan.csv`: `x_mm, y_mm, z_mm`: a scan of the formed part's upper surface after unclamping
  (a point cloud, any order), for the CAD-like check against a target mesh (`check --target-stl`).
- optional `truth.json`: written by the lab for made-up runs; `read_run` never opens it.

All streams share one clock: `t_s = 0` at the start of the commanded path. Extra columns are ignored.
Inside the code everything is SI (m, N, s). Lengths carry their unit in the column name: the writers write the
canonical `_mm` columns; a reader also takes a length declared in metres (`x_m`, `y_m`, `z_m`), never both
spellings of one column (`twin.base.units`).

Reading and validating: `twin.runs.read`; writing (atomic, never over an input): `twin.runs.write`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.signals import interp_rows
from twin.errors import DataFileError, InputError, ModelError, RunFormatError
from twin.process.description import Process
from twin.process.process_file import process_from_record, process_record
from twin.process.toolpath.placement import Placement
from twin.robot.description import load_robot
from twin.robot.facts import RobotDescription

RUN_FORMAT = "tx200-twin-run/1"
RUN_FRAME = "sheet"
POSITION_COLUMNS = ("t_s", "x_mm", "y_mm", "z_mm")
FORCE_COLUMNS = ("t_s", "fx_n", "fy_n", "fz_n")
PROFILE_COLUMNS = ("x_mm", "z_mm")
SCAN_COLUMNS = ("x_mm", "y_mm", "z_mm")
REQUIRED_META = ("format", "frame", "scenario", "tool_length_m", "tracker_rate_hz")
RATE_TOLERANCE = 0.05  # meta rates may differ from the median sample interval by 5 %
CLOCK_TOLERANCE_S = 1.0  # a stream starting further than this from the commanded start has another clock
START_TOLERANCE_S = 1e-3  # the commanded path starts at t_s = 0


def frozen_array(values: Any, shape_tail: tuple[int, ...], name: str) -> np.ndarray:
    """`values` as a read-only float array of shape (n, *shape_tail), all finite; InputError naming `name`."""
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
        t_s = frozen_array(self.t_s, (), "Stream.t_s")
        values = frozen_array(self.values, (3,), "Stream.values")
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
        part_scan: Scanned points of the formed part's surface [m], shape (n, 3), or None.
    """

    directory: Path | None
    meta: dict[str, Any]
    commanded: Stream
    tracker: Stream
    forces: Stream | None = None
    part_profile: tuple[np.ndarray, np.ndarray] | None = field(default=None)
    part_scan: np.ndarray | None = field(default=None)

    def __post_init__(self) -> None:
        if self.part_scan is not None:
            scan = np.asarray(self.part_scan)
            if scan.ndim != 2 or scan.shape[1] != 3:
                raise InputError(f"part_scan has shape {scan.shape}, expected (n, 3)")
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


def run_meta(
    *,
    scenario: str,
    source: str,
    tracker_rate_hz: float,
    sensor_rate_hz: float,
    seed: int,
    tool_length_m: float,
    placement: Placement | None = None,
    robot: str | None = None,
    force_model: str | None = None,
    process: Process | None = None,
) -> dict[str, Any]:
    """The `meta.json` of a made-up run: format, frame, tool length, the scenario, rates and seed.

    Args:
        scenario: `nominal`, `compensated`, `loadtest`, `cnc` or free text.
        source: What made the run, in words.
        tracker_rate_hz: Tracker (or machine position) rate [Hz].
        sensor_rate_hz: Force sensor rate [Hz].
        seed: Seed of the run's noise.
        tool_length_m: Flange to tool tip of the robot's tool [m].
        placement: The sheet's placement in the robot base; recorded unless it is the cell's own.
        robot: The robot's name, recorded when given.
        force_model: The sheet's force model (`twin.process.force.registry`), recorded when given.
        process: The sheet and tool the run formed with (`process_record`), recorded when given.
    """
    extra: dict[str, Any] = {} if placement is None or placement.is_default else {"placement": placement.to_json()}
    if robot is not None:
        extra["robot"] = robot
    if force_model is not None:
        extra["force_model"] = force_model
    if process is not None:
        extra["process"] = process_record(process)
    return {
        "format": RUN_FORMAT,
        "scenario": scenario,
        "frame": RUN_FRAME,
        "source": source,
        "tool_length_m": float(tool_length_m),
        "tracker_rate_hz": float(tracker_rate_hz),
        "sensor_rate_hz": float(sensor_rate_hz),
        "seed": seed,
        **extra,
    }


def run_placement(meta: Mapping[str, Any], source: str | Path = "meta.json") -> Placement:
    """The sheet placement a run was made at (`meta.json`'s `placement`; absent: the cell's, yaw 0).

    Raises:
        RunFormatError: The entry is not {"origin_base_mm": null or 3 numbers, "yaw_deg": a number}.
    """
    try:
        return Placement.from_json(meta.get("placement"), source)
    except DataFileError as exc:
        raise RunFormatError(exc.path, exc.detail) from None


def run_robot(meta: Mapping[str, Any], source: str | Path = "meta.json") -> RobotDescription:
    """The robot a run was made with (`meta.json`'s `robot`: a shipped name or a description file; absent, as in
    runs before it was recorded: the default robot).

    Raises:
        RunFormatError: The entry is not a string, or names no robot the twin can load.
    """
    name = meta.get("robot")
    if name is not None and not isinstance(name, str):
        raise RunFormatError(source, f"robot = {name!r}: expected a robot's name or description file")
    if name is not None and Path(name).suffix and not Path(name).is_absolute():
        name = str(Path(source).parent / name)  # the run's own copy of a user's robot (`runs.write.ROBOT_COPY`)
    try:
        return load_robot(name)
    except ModelError as exc:
        raise RunFormatError(source, f"robot: {exc}") from None


def run_process(meta: Mapping[str, Any], base: Process, source: str | Path = "meta.json") -> Process:
    """`base` with the process a run records (`meta.json`'s `process`; absent, as in runs before it was
    recorded: `base` unchanged).

    Raises:
        RunFormatError: The entry is not an object of valid values (naming the key).
    """
    if "process" not in meta:
        return base
    try:
        return process_from_record(meta["process"], base)
    except InputError as exc:
        raise RunFormatError(source, str(exc)) from None
