"""`compensate --forces-from RUN`: the next part's command from the last part's run, its measured forces driving the
twin's robot (`twin.analysis.next_part`), written as a command (commanded.csv format) with the record of the forces
it assumed (`CMD.compensation.json`: the measured ones), so that `check` names a gain's cause as for any command.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.compensate import TWIN_MAX_ITER, TWIN_TOL_M
from twin.analysis.compensation_record import CompensationRecord, write_record
from twin.analysis.next_part import NextCommand, next_command
from twin.analysis.resolve import resolve_spec, spec_for_run
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.compensate import write_command
from twin.apps.tasks.inputs import ideal_path
from twin.errors import InputError
from twin.runs.read import read_run
from twin.sim.spec import TwinSpec


@dataclass(frozen=True)
class NextPartRequest:
    """The next part from the last one.

    Attributes:
        forces_from: The last part's run (its command and measured forces).
        ideal: The part's ideal path U_ID (CSV t_s, x_mm, y_mm, z_mm), the program the run formed.
        out: The command to write (commanded.csv format; its record goes beside it).
        model: A model file (the learned robot), or None (the run's robot with its shipped model).
        robot: A robot name or description file, or None (the run's).
        cell: A `--cell` file's record (`CellDeclaration.record`), or None.
    """

    forces_from: Path
    ideal: Path
    out: Path
    model: Path | None = None
    robot: str | None = None
    cell: Mapping[str, Any] | None = None

    def inputs(self) -> list[Path]:
        """The files it reads (which its outputs must not replace)."""
        return [p for p in (self.forces_from, self.ideal, self.model) if p is not None]


#: The `compensate` options that do not go with `--forces-from` (their value when not given): another method's or
#: another source's of the command's forces, the sheet's (the run's forces are its), the placement (the run's), the
#: twin's iteration (none runs), the part and the dynamic twin.
NOT_WITH_FORCES_FROM: dict[str, Any] = {
    "stiffness": None, "history": None, "symmetry": None, "force_model": "auto", "process": None, "material": None,
    "thickness_mm": None, "tool_radius_mm": None, "origin_mm": None, "yaw_deg": None, "tol_mm": 1e3 * TWIN_TOL_M,
    "max_iter": TWIN_MAX_ITER, "target_stl": None, "learn_from": None, "figure": None, "rrd": None, "dynamic": False}


def next_part_request(options: Mapping[str, Any]) -> NextPartRequest:
    """The request from `compensate`'s options (the CLI's, by name), or an `InputError` naming those given that do
    not go with `--forces-from` (`NOT_WITH_FORCES_FROM`)."""
    forces_from, ideal = options["forces_from"], options.get("ideal")
    if ideal is None:
        raise InputError(f"--forces-from {forces_from} needs --ideal PART.csv: the program that run formed")
    given = [f"--{k.replace('_', '-')} {options[k]}" for k, unset in NOT_WITH_FORCES_FROM.items()
             if options.get(k, unset) != unset]
    if options.get("method", "twin") != "twin":
        given.insert(0, f"--method {options['method']}")
    if given:
        raise InputError(f"--forces-from {forces_from} takes the run's forces, sheet and placement as they were: "
                         f"expected --method twin without {', '.join(given)}")
    return NextPartRequest(forces_from, ideal, options["out"], model=options.get("model"), robot=options.get("robot"),
                           cell=options.get("cell_record"))


@dataclass(frozen=True)
class NextPartReport(Report):
    """The next command and what the twin's robot saw of the last part."""

    request: NextPartRequest
    spec: TwinSpec
    next: NextCommand
    record_file: Path

    def _deflection_mm(self) -> tuple[float, float]:
        """The twin's deflection along the path: (rms, max) [mm]."""
        bend_mm = 1e3 * np.linalg.norm(self.next.deflection_m, axis=1)
        return float(np.sqrt(np.mean(bend_mm**2))), float(np.max(bend_mm))

    def lines(self) -> list[str]:
        rms_mm, max_mm = self._deflection_mm()
        return [f"compensate (the next part): {self.spec.robot.name}'s twin deflects the tool by {rms_mm:.3f} mm rms "
                f"(max {max_mm:.2f}) under the forces {self.request.forces_from} measured; {self.request.ideal} less "
                f"that -> {self.request.out}",
                f"  record: {self.record_file} (the forces it assumes: the last part's, measured)"]

    def record(self) -> dict[str, Any]:
        rms_mm, max_mm = self._deflection_mm()
        return {"method": "twin", "forces_from": str(self.request.forces_from), "ideal": str(self.request.ideal),
                "out": str(self.request.out), "robot": self.spec.robot.name, "samples": len(self.next.t_s),
                "deflection_rms_mm": rms_mm, "deflection_max_mm": max_mm, "record": str(self.record_file)}


def next_part_task(request: NextPartRequest, note: Note = silent) -> NextPartReport:
    """Write the next part's command (module docstring).

    Raises:
        InputError: The run or the ideal path cannot give it (`twin.analysis.next_part.next_command`), or `out`
            would replace one of them (`write_command`'s protection).
    """
    run = read_run(request.forces_from)
    ideal = ideal_path(request.ideal)
    spec = spec_for_run(run, resolve_spec(cell=request.cell, model=request.model, robot=request.robot, run=run,
                                          p_sheet_m=ideal.p_sheet_m, note=note))
    nxt = next_command(run, ideal.t_s, ideal.p_sheet_m, spec.build(), f"--ideal {request.ideal}")
    write_command(request.out, nxt.t_s, nxt.p_cmd_sheet_m, request.inputs())
    record_file = write_record(request.out, CompensationRecord("twin", nxt.t_s, nxt.f_measured_n))
    return NextPartReport(request, spec, nxt, record_file)
