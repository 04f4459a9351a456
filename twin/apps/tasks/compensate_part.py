"""`compensate --target-stl`: the command whose formed part lies on a design surface, springback included, found
on the twin (`twin.analysis.part_compensation`), or learned from the last part's scan (`twin.analysis.scan_learning`:
as the part's miss of the twin's prediction, or as the error of the surface each sample formed or under its tip);
with the deviation maps and a rerun recording of its stages if asked.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import trimesh

from twin.analysis.compensation_record import CompensationRecord, write_record
from twin.analysis.part_compensation import (
    PartCompensation,
    PartStage,
    compensate_part,
    part_stats,
    predicted_surface,
)
from twin.analysis.scan_learning import learn_from_scan, twin_discrepancy
from twin.analysis.surface_check import read_target_mesh, region_deviation
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.inputs import ideal_path
from twin.errors import InputError
from twin.process.description import Process
from twin.process.force.registry import build_force_field
from twin.process.part.match import check_same_part
from twin.process.toolpath.groove import ToolPath, label_passes
from twin.runs.format import Run, Stream, run_process
from twin.runs.read import read_run
from twin.runs.write import write_path_csv

if TYPE_CHECKING:
    from twin.apps.tasks.compensate import CompensateRequest

Found = tuple[np.ndarray, np.ndarray, list[PartStage], dict[str, Any]]
"""A part command: its times [s] (n,), the command, sheet frame [m] (n, 3), its stages and its numbers."""


@dataclass(frozen=True)
class PartReport(Report):
    """A command compensated to a design surface.

    Attributes:
        request: What was compensated (its `target_stl`, `learn_from`).
        t_s: The command's times [s], shape (n,).
        p_cmd_sheet_m: The command written, sheet frame [m], shape (n, 3).
        stages: The part's stages against the design (the last part's scan, the twin's predicted parts).
        numbers: The method's numbers, under the keys of the JSON document (`record`).
        figure: The deviation maps written, or None.
        rrd: The rerun recording written, or None.
    """

    request: CompensateRequest
    t_s: np.ndarray
    p_cmd_sheet_m: np.ndarray
    stages: list[PartStage]
    numbers: dict[str, Any]
    figure: str | None = None
    rrd: str | None = None
    record_file: str | None = None

    @property
    def method(self) -> str:
        """"learn" (from the last part's scan) or "part" (on the twin alone)."""
        return "part" if self.request.learn_from is None else "learn"

    def lines(self) -> list[str]:
        last = self.stages[-1]
        part = part_stats(last.deviation)["part"]
        return [f"compensate ({self.method}) to {Path(str(self.request.target_stl)).name}: {last.name}: the part "
                f"{part['rms_mm']:.3f} mm rms, max {part['max_mm']:.3f} mm, mean {part['mean_mm']:+.3f} mm from the "
                f"design ({len(self.stages)} stages) -> {self.request.out}"
                + ("" if self.record_file is None else f", {self.record_file}")]

    def record(self) -> dict[str, Any]:
        outputs = {name: path for name, path in (("figure", self.figure), ("rrd", self.rrd),
                                                 ("record", self.record_file)) if path is not None}
        return {"method": self.method, "out": self.request.out, **self.numbers, **outputs}


def compensate_part_task(request: CompensateRequest, note: Note = silent) -> PartReport:
    """Compensate the part to `request.target_stl` and write the command (and the figure, the recording).

    Raises:
        InputError: A run without part_scan.csv to learn from, a force model that keeps no surface, a design or a
            scan of another part than the path's (`twin.process.part.match`).
        DataFileError: A bad design, run or path file (naming the file).
    """
    assert request.target_stl is not None
    design = read_target_mesh(request.target_stl)
    protect = request.inputs()
    if request.learn_from is None:
        ideal = ideal_path(request.ideal)
        spec = request.spec(ideal.p_sheet_m, note=note)
        check_same_part(ideal.p_sheet_m, design, f"--target-stl {request.target_stl}", path_what=(
            "the default ideal path (the groove; --ideal FILE)" if request.ideal is None else f"--ideal {request.ideal}"),
            tool_radius_m=spec.process.tool_radius_m)
        result = compensate_part(ideal, spec.build(), design,
                                 iterations=request.part_iterations, tol_m=1e-3 * request.tol_mm, progress=note)
        found: Found = (ideal.t_s, result.compensation.p_cmd_sheet_m, result.stages(),
                        {"iterations": request.part_iterations, **_surface_rms(result)})
    else:
        last = read_run(request.learn_from)
        if last.part_scan is None:
            raise InputError(f"--learn-from {request.learn_from}: the run has no part_scan.csv to learn from")
        _check_last_part(request, design, last)
        scanned = PartStage(f"scan of {Path(request.learn_from).name}", "scanned",
                            region_deviation(last.part_scan, design))
        learn = _learn_on_twin if request.learn_at == "twin" else _learn_from_scan
        found = learn(request, design, last, scanned, note)
    t_s, command, stages, numbers = found
    write_path_csv(Stream(np.asarray(t_s, dtype=float), np.asarray(command, dtype=float)), request.out,
                   protect=protect)  # the command, as `compensate` writes one
    record_file = write_record(request.out, _record(request, t_s, command))
    figure = rrd = None
    if request.figure is not None:
        from twin.viz.surface_figures import plot_part_stages

        whose = "the last part's scan" if request.learn_from else "the twin's part"
        figure = str(plot_part_stages(request.figure, stages, title=f"{Path(request.target_stl).name}: {whose}",
                                      protect=protect))
    if request.rrd is not None:
        from twin.viz.part_recording import record_part

        rrd = str(record_part(request.rrd, design, stages, protect=protect))
    return PartReport(request, t_s, command, stages, numbers, figure, rrd, str(record_file))


def _check_last_part(request: CompensateRequest, design: trimesh.Trimesh, last: Run) -> None:
    """Refuse a design or a last part's scan of another part than the ideal path's (`twin.process.part.match`)."""
    assert last.part_scan is not None and request.learn_from is not None
    radius = run_process(last.meta, Process(), Path(request.learn_from) / "meta.json").tool_radius_m
    # the ideal path (a springback-compensated command runs deeper than its part on purpose), else the run's command
    path = last.commanded.values if request.ideal is None else ideal_path(request.ideal).p_sheet_m
    named = f"the command of --learn-from {request.learn_from}" if request.ideal is None else f"--ideal {request.ideal}"
    check_same_part(path, design, f"--target-stl {request.target_stl}", path_what=named,
                    tool_radius_m=radius)
    check_same_part(path, last.part_scan, f"the scan {Path(request.learn_from) / 'part_scan.csv'}",
                    path_what=named, tool_radius_m=radius)


def _record(request: CompensateRequest, t_s: np.ndarray, command_m: np.ndarray) -> CompensationRecord:
    """What the part's command assumed, for `check`: the design it was compensated to (so that its path is not
    judged against the ideal one) and the twin's forces along the command written (sheet frame [N])."""
    passes, direction = label_passes(command_m[:, 0])
    path = ToolPath(t_s=t_s, p_sheet_m=command_m, pass_index=passes, direction=direction)
    forces = build_force_field(request.spec(command_m).process).rigid_forces(path)
    return CompensationRecord("twin", t_s, forces, design_file=str(request.target_stl))


def _learned(request: CompensateRequest, at: str) -> dict[str, Any]:
    """The learning's settings, under the JSON's keys."""
    return {"learned_from": request.learn_from, "gain": request.learn_gain,
            "smoothing_mm": request.learn_smoothing_mm, "at": at}


def _surface_rms(result: PartCompensation) -> dict[str, Any]:
    """The rms deviation of the twin's predicted part by region at each iteration [mm]."""
    return {"predicted_surface_rms_mm_per_iteration": [{region: stats["rms_mm"] for region, stats in e.items()}
                                                       for e in result.error_per_iteration]}


def _learn_on_twin(request: CompensateRequest, design: trimesh.Trimesh, last: Run, scanned: PartStage,
                   note: Note) -> Found:
    """The twin's part compensation to the design minus the last part's miss of the twin's prediction."""
    assert last.part_scan is not None
    scan = last.part_scan
    ideal = ideal_path(request.ideal)
    twin = request.spec(ideal.p_sheet_m, note=note).build()
    miss_of = twin_discrepancy(scan, predicted_surface(twin, last.commanded.t_s, last.commanded.values),
                               1e-3 * request.learn_smoothing_mm)
    result = compensate_part(ideal, twin, design, iterations=request.part_iterations, tol_m=1e-3 * request.tol_mm,
                             discrepancy=lambda xy: request.learn_gain * miss_of(xy))
    miss = miss_of(scan[:, :2])
    numbers = {**_learned(request, "twin"), "iterations": request.part_iterations,
               "twin_miss_rms_mm": 1e3 * float(np.sqrt(np.nanmean(miss**2))), **_surface_rms(result)}
    return ideal.t_s, result.compensation.p_cmd_sheet_m, [scanned, *result.stages()], numbers


def _learn_from_scan(request: CompensateRequest, design: trimesh.Trimesh, last: Run, scanned: PartStage,
                     note: Note) -> Found:
    """The last command moved by the error of the surface each sample formed ("formed") or under its tip."""
    assert last.part_scan is not None and request.learn_from is not None
    radius = run_process(last.meta, Process(), Path(request.learn_from) / "meta.json").tool_radius_m
    learned = learn_from_scan(last.commanded.values, last.part_scan, design, gain=request.learn_gain,
                              smoothing_m=1e-3 * request.learn_smoothing_mm, tool_radius_m=radius,
                              at=request.learn_at)
    measured = learned.measured_m
    seen = np.isfinite(measured)
    numbers = {
        **_learned(request, request.learn_at), "tool_radius_mm": 1e3 * radius,
        "samples_forming_scanned_points": int((learned.formed_points > 0).sum()),
        "samples_seen": int(seen.sum()), "samples": len(seen),
        "measured_error_rms_mm": 1e3 * float(np.sqrt(np.mean(measured[seen] ** 2))) if seen.any() else None,
    }
    return last.commanded.t_s, learned.command_m, [scanned], numbers
