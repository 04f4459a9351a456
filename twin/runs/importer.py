"""Import a cell's raw exports into a `tx200-twin-run/1` directory, as described by a TOML mapping.

Steps: read each raw table (`raw_tables`), take the commanded path's first time as the shared clock's zero,
register the tracker to the sheet frame (`registration`), turn sensor forces into the sheet's force on the
tool (`gravity`), align the tracker's and the sensor's clocks (`clock`), keep the samples inside the
commanded path's time span, and write the run with `write_run` (validated by `read_run`, atomic, never over
an input). What was done (transform, fit residual, offsets with their uncertainty) goes to `meta.json`
under `import`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from twin.errors import AssumptionWarning, InputError
from twin.process.description import Process
from twin.process.process_file import ProcessDeclaration, process_record
from twin.runs.clock import ClockFit, check_overlap, onset_offset, refine_on_reversals
from twin.runs.format import RUN_FORMAT, Run, Stream
from twin.runs.gravity import contact_force_sheet
from twin.runs.mapping import ClockSpec, ImportMapping, load_mapping
from twin.runs.raw_tables import RawTable, read_raw_table
from twin.runs.toml_keys import ClockError, key_line
from twin.runs.write import write_run


@dataclass(frozen=True)
class ImportResult:
    """An imported run and how it was assembled.

    Attributes:
        run: The run in the sheet frame on the shared clock, SI units.
        report: The `import` record stored in meta.json (registration, clocks, sample counts, inputs).
    """

    run: Run
    report: dict[str, Any]


def _clock_error(mapping: ImportMapping, stream: str, spec: ClockSpec, message: str) -> ClockError:
    key = f"{stream}.clock.offset_s" if spec.method == "offset" else f"{stream}.clock.method"
    line = key_line(mapping.path.read_text(encoding="utf-8-sig"), key)
    return ClockError(mapping.path, f"{stream}: {message}", line, key)


def _align(
    mapping: ImportMapping, stream: str, spec: ClockSpec, table: RawTable, signal: np.ndarray, commanded: Stream
) -> ClockFit:
    assert table.t_s is not None
    if spec.method == "offset":
        assert spec.offset_s is not None
        return ClockFit(spec.offset_s, 0.0, "offset")
    p_cmd = commanded.values
    if spec.method == "force_onset":
        reference = np.maximum(0.0, p_cmd[0, 2] - p_cmd[:, 2])  # depth below the start [m]
        magnitude = np.linalg.norm(signal, axis=1)
    else:  # positions, fitted per axis with one shared lag
        reference, magnitude = p_cmd, signal
    try:
        fit = onset_offset(
            table.t_s, magnitude, commanded.t_s, reference, max_offset_s=spec.max_offset_s, method=spec.method
        )
        if spec.method == "force_onset":
            fit = refine_on_reversals(table.t_s, signal, commanded.t_s, p_cmd, fit)
        return fit
    except InputError as exc:
        raise _clock_error(mapping, stream, spec, f"{spec.method}: {exc}") from None


def _crop(
    mapping: ImportMapping, stream: str, spec: ClockSpec, t_s: np.ndarray, values: np.ndarray, t_end_s: float
) -> Stream:
    try:
        check_overlap(t_s, t_end_s)
    except InputError as exc:
        raise _clock_error(mapping, stream, spec, str(exc)) from None
    keep = (t_s >= 0.0) & (t_s <= t_end_s)
    return Stream(t_s[keep], values[keep])


class _AlignedStream(NamedTuple):
    """A stream on the shared clock, cropped to the commanded path's time span, and its clock fit."""

    stream: Stream
    clock: ClockFit


def _read_commanded(mapping: ImportMapping) -> Stream:
    """The commanded path [m] with its first time as the shared clock's zero [s]."""
    raw_cmd = read_raw_table(mapping.commanded)
    assert raw_cmd.t_s is not None
    return Stream(raw_cmd.t_s - raw_cmd.t_s[0], raw_cmd.values)


def _import_tracker(mapping: ImportMapping, commanded: Stream, t_end_s: float) -> _AlignedStream:
    """The tracker's tool tip registered to the sheet frame [m], on the shared clock up to `t_end_s` [s]."""
    raw_tracker = read_raw_table(mapping.tracker)
    assert raw_tracker.t_s is not None
    p_tracker_sheet = mapping.registration.apply(raw_tracker.values)
    tracker_clock = _align(mapping, "tracker", mapping.tracker_clock, raw_tracker, p_tracker_sheet, commanded)
    tracker = _crop(
        mapping,
        "tracker",
        mapping.tracker_clock,
        raw_tracker.t_s - tracker_clock.offset_s,
        p_tracker_sheet,
        t_end_s,
    )
    return _AlignedStream(tracker, tracker_clock)


def _import_forces(mapping: ImportMapping, commanded: Stream, t_end_s: float) -> _AlignedStream:
    """The sheet's force on the tool, sheet frame [N], from the sensor's reading, on the shared clock [s]."""
    raw_forces = read_raw_table(mapping.forces)
    assert raw_forces.t_s is not None
    s = mapping.sensor
    f_sheet = contact_force_sheet(raw_forces.values, s.R_sheet_sensor, s.tool_mass_kg, s.gravity_sheet_m_s2)
    forces_clock = _align(mapping, "forces", mapping.forces_clock, raw_forces, f_sheet, commanded)
    forces = _crop(
        mapping, "forces", mapping.forces_clock, raw_forces.t_s - forces_clock.offset_s, f_sheet, t_end_s
    )
    return _AlignedStream(forces, forces_clock)


def _read_profile(mapping: ImportMapping) -> tuple[np.ndarray, np.ndarray] | None:
    """The part profile (x_m, z_m) sorted by x [m], or None when the mapping has none."""
    if mapping.profile is None:
        return None
    raw_profile = read_raw_table(mapping.profile)
    order = np.argsort(raw_profile.values[:, 0], kind="stable")
    return (raw_profile.values[order, 0], raw_profile.values[order, 1])


def _import_report(
    mapping: ImportMapping, commanded: Stream, tracker: _AlignedStream, forces: _AlignedStream
) -> dict[str, Any]:
    """The `import` record of meta.json: inputs, registration [mm], clock fits [s], sensor, sample counts."""
    reg = mapping.registration
    s = mapping.sensor
    return {
        "mapping": str(mapping.path),
        "inputs": [str(p) for p in mapping.inputs()[1:]],
        "registration": {
            "T_sheet_tracker": reg.T_sheet_tracker.tolist(),
            "points": reg.points,
            "residual_rms_mm": 1e3 * reg.residual_rms_m,
            "residual_max_mm": 1e3 * reg.residual_max_m,
        },
        "clocks": {
            name: {
                "method": fit.method,
                "offset_s": fit.offset_s,
                "sigma_s": fit.sigma_s,
                "refined_on": fit.refined_on,
            }
            for name, fit in (("tracker", tracker.clock), ("forces", forces.clock))
        },
        "sensor": {
            "R_sheet_sensor": s.R_sheet_sensor.tolist(),
            "tool_mass_kg": s.tool_mass_kg,
            "com_sensor_mm": (1e3 * s.com_sensor_m).tolist(),
            "gravity_sheet_m_s2": s.gravity_sheet_m_s2.tolist(),
        },
        "samples": {
            "commanded": len(commanded.t_s),
            "tracker": len(tracker.stream.t_s),
            "forces": len(forces.stream.t_s),
        },
    }


def import_run(mapping: ImportMapping) -> ImportResult:
    """Assemble a run from the raw exports a mapping describes (nothing is written).

    Args:
        mapping: A loaded mapping (`load_mapping`).

    Returns:
        The run and the import record.

    Raises:
        MappingError: A raw file is malformed (file, line, column named). ClockError: a stream does not
            overlap the commanded path on the shared clock, or its onset cannot be found.
    """
    commanded = _read_commanded(mapping)
    t_end = float(commanded.t_s[-1])
    tracker = _import_tracker(mapping, commanded, t_end)
    forces = _import_forces(mapping, commanded, t_end)
    profile = _read_profile(mapping)
    report = _import_report(mapping, commanded, tracker, forces)
    meta = {
        "format": RUN_FORMAT,
        "frame": "sheet",
        "scenario": mapping.scenario,
        "source": "tx200-twin import",
        "tool_length_m": mapping.tool_length_m,
        "tracker_rate_hz": round(1.0 / tracker.stream.median_interval_s, 6),
        "sensor_rate_hz": round(1.0 / forces.stream.median_interval_s, 6),
        "notes": mapping.notes,
        "import": report,
        **_cell_meta(mapping),
    }
    run = Run(None, meta, commanded, tracker.stream, forces.stream, profile)
    return ImportResult(run, report)


def _cell_meta(mapping: ImportMapping) -> dict[str, Any]:
    """What a run records of its cell, as a lab run does: the robot (when named) and the sheet's placement (when
    not the robot's default)."""
    from twin.process.toolpath.placement import Placement

    meta: dict[str, Any] = {} if mapping.robot is None else {"robot": mapping.robot}
    origin, yaw = mapping.placement.get("origin_mm"), mapping.placement.get("yaw_deg")
    place = Placement(None if origin is None else tuple(float(v) / 1e3 for v in origin),  # type: ignore[arg-type]
                      math.radians(yaw or 0.0))
    return meta if place.is_default else {**meta, "placement": place.to_json()}


def with_cell(
    mapping: ImportMapping,
    robot: str | None = None,
    origin_mm: Any = None,
    yaw_deg: float | None = None,
    cell: Mapping[str, Any] | None = None,
) -> ImportMapping:
    """The mapping with the command's `--robot`, `--origin-mm`, `--yaw-deg` and `--cell` (a cell file's record)
    laid over and under it by `twin.analysis.resolve.PRECEDENCE`: a typed flag > the mapping's `[run]` (the run's
    record) > the cell > the robot's defaults; its tool length (`run.tool_length_mm`) > the cell's > the robot's; the
    sensor's axes (`forces.sensor.R_sheet_sensor`) > the cell's `[ft_sensor]` mount with the tool held down and the
    sheet's yaw (`twin.robot.ft_mount.sensor_in_sheet`) > the sheet's axes.

    Raises:
        InputError: `--robot` or the cell names another robot than the mapping's `run.robot` (both named).
    """
    from twin.robot.description import load_robot

    cell_robot = None if cell is None or robot is not None else cell.get("robot")
    if mapping.robot is not None:
        made = load_robot(mapping.robot)
        for what, other in (("--robot", robot), (f"the cell {(cell or {}).get('file')}", cell_robot)):
            if other is not None and load_robot(other).source != made.source:
                raise InputError(f"{what} gives robot {load_robot(other).name!r}, but the mapping {mapping.path} "
                                 f"says run.robot = {mapping.robot!r} ({made.name!r}); expected the same robot")
    chosen = robot or mapping.robot or cell_robot
    sheet = dict((cell or {}).get("sheet") or {})
    placement = {
        "origin_mm": next((v for v in (origin_mm, mapping.placement.get("origin_mm"), sheet.get("origin_mm"))
                           if v is not None), None),
        "yaw_deg": next((v for v in (yaw_deg, mapping.placement.get("yaw_deg"), sheet.get("yaw_deg"))
                         if v is not None), None),
    }
    length_m = mapping.tool_length_m
    cell_length = ((cell or {}).get("tool") or {}).get("length_mm")
    if not mapping.tool_length_given:
        length_m = 1e-3 * float(cell_length) if cell_length is not None else load_robot(chosen).tool_length_m
    elif cell_length is not None and abs(1e3 * length_m - float(cell_length)) > 0.5:  # said: a copied example's?
        warnings.warn(f"the mapping {mapping.path}'s run.tool_length_mm = {1e3 * length_m:g} mm wins over the cell's "
                      f"{float(cell_length):g} mm tool (the run's record > the cell); leave it out of the mapping if "
                      "the cell's tool made the run", AssumptionWarning, stacklevel=2)
    sensor = mapping.sensor
    mount = (cell or {}).get("ft_sensor")
    if mount is not None and not mapping.sensor_rotation_given:
        from twin.robot.ft_mount import sensor_in_sheet

        sensor = replace(sensor, R_sheet_sensor=sensor_in_sheet(chosen, mount["rpy_deg"], placement["yaw_deg"]))
    return replace(mapping, robot=None if chosen is None else str(chosen), placement=placement, tool_length_m=length_m,
                   sensor=sensor)


def import_to_directory(
    mapping_path: str | Path,
    out: str | Path,
    *,
    overwrite: bool = False,
    robot: str | None = None,
    origin_mm: Any = None,
    yaw_deg: float | None = None,
    cell: Mapping[str, Any] | None = None,
    process: ProcessDeclaration | None = None,
) -> ImportResult:
    """Load a mapping, import its raw exports and write the run directory atomically.

    Args:
        mapping_path: The TOML mapping.
        out: The run directory to write (never one that holds an input).
        overwrite: Replace an existing non-empty directory.
        robot, origin_mm, yaw_deg, cell: The command's `--robot`, `--origin-mm`, `--yaw-deg` as typed and its
            `--cell` record (`with_cell`); the run records the robot, the placement and the cell as a lab run does.
        process: The sheet and tool declared (a `--cell`'s `[process]`): the run records it as its process (over
            the thesis's), as a lab run records the process it formed; None or nothing declared: none recorded.

    Returns:
        The imported run (its `directory` set to `out`) and the import record.
    """
    mapping = with_cell(load_mapping(mapping_path), robot, origin_mm, yaw_deg, cell)
    result = import_run(mapping)
    declared = {} if process is None or not process.origins else {
        "process": process_record(process.applied_to(Process()))}
    if cell is not None or declared:
        cell_meta = {} if cell is None else {"cell": dict(cell)}
        result = ImportResult(replace(result.run, meta={**result.run.meta, **cell_meta, **declared}), result.report)
    target = write_run(out, result.run, overwrite=overwrite, protect=mapping.inputs())
    run = Run(
        target,
        result.run.meta,
        result.run.commanded,
        result.run.tracker,
        result.run.forces,
        result.run.part_profile,
    )
    return ImportResult(run, result.report)
