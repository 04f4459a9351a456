"""`lab --scenario cnc`: the thesis's CNC validation (§2.3) on a rigid machine, the lab's scenario without a robot."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.analysis.resolve import resolve_process
from twin.apps.tasks.base import Note, Report
from twin.apps.tasks.lab_output import with_records
from twin.process.description import Process
from twin.process.process_file import process_record
from twin.process.toolpath.groove import ToolPath, label_passes
from twin.runs.read import lab_commanded
from twin.runs.write import write_run

if TYPE_CHECKING:
    from twin.apps.tasks.lab import LabRequest


@dataclass(frozen=True)
class CncReport(Report):
    """The rigid machine's run (thesis §2.3).

    Attributes:
        out: The run folder written.
        seed: The seed of the noise.
        force_samples: F/T samples measured (10 Hz).
        peak_fz_n: The largest Fz measured [N].
        formed_depth_mm: The part's depth after springback [mm].
        process: The process the run formed.
    """

    out: Path
    seed: int
    force_samples: int
    peak_fz_n: float
    formed_depth_mm: float
    process: Process

    def lines(self) -> list[str]:
        process = self.process
        return [f"lab cnc: rigid machine, {self.force_samples} force samples at 10 Hz, peak Fz {self.peak_fz_n:.0f} N, "
                f"formed depth after springback {self.formed_depth_mm:.2f} mm ({process.material}, "
                f"{1e3 * process.thickness_m:g} mm, {process.force_model} model) -> {self.out}"]

    def record(self) -> dict[str, Any]:
        return {"scenario": "cnc", "out": self.out, "seed": self.seed, "force_samples": self.force_samples,
                "peak_fz_n": self.peak_fz_n, "formed_depth_mm": self.formed_depth_mm,
                "process": {**process_record(self.process), "force_model": self.process.force_model}}


def cnc_task(request: LabRequest, note: Note) -> CncReport:
    """The thesis's CNC validation (§2.3) on a rigid machine: the groove, or any commanded path, formed with the
    declared process; forces at 10 Hz, the part after springback (the y = 0 section, and a scan of the surface
    where the force model keeps one)."""
    commanded, protect = lab_commanded(request.scenario, request.commanded)
    pass_index, direction = label_passes(commanded.values[:, 0])
    path = ToolPath(t_s=commanded.t_s, p_sheet_m=commanded.values, pass_index=pass_index, direction=direction)
    process = resolve_process(Process(), request.declaration, request.force_model, path.p_sheet_m, note=note)
    from twin.lab.cnc import run_cnc

    run, truth = run_cnc(seed=request.seed, path=path, process=process)
    run = with_records(run, request)
    write_run(request.out, run, truth=truth, overwrite=request.overwrite, protect=protect)
    assert run.part_profile is not None and run.forces is not None
    return CncReport(request.out, request.seed, len(run.forces.t_s), float(np.max(run.forces.values[:, 2])),
                     -1e3 * float(np.min(run.part_profile[1])), process)
