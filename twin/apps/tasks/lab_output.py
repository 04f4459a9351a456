"""What a lab writes, whatever its plant (`twin.apps.tasks.lab`, `lab_dynamic`, `lab_cnc`): the refusal of an existing
output, a Method 1 load-test file and its report, and the records a run keeps of its request (the command's
compensation record, for `check`, and the cell)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.analysis.compensation_record import CompensationRecord, read_record
from twin.apps.tasks.base import Report
from twin.base.csvio import write_table
from twin.errors import InputError
from twin.runs.format import Run

if TYPE_CHECKING:
    from twin.apps.tasks.lab import LabRequest


@dataclass(frozen=True)
class LoadTestReport(Report):
    """A Method 1 load-test file written (`identify --method 1`).

    Attributes:
        out: The CSV written (fx_n, fy_n, fz_n [N], dx_mm, dy_mm, dz_mm [mm]).
        cases: The load cases.
        plant: "quasi-static" or "dynamic".
    """

    out: Path
    cases: int
    plant: str = "quasi-static"

    def lines(self) -> list[str]:
        if self.plant == "dynamic":
            return [f"lab loadtest (dynamic plant): {self.cases} load cases at home -> {self.out}"]
        return [f"lab loadtest: {self.cases} load cases at home (thesis Table 4.2) -> {self.out}"]

    def record(self) -> dict[str, Any]:
        plant = {"plant": "dynamic"} if self.plant == "dynamic" else {}
        return {"scenario": "loadtest", **plant, "out": self.out, "cases": self.cases}


def check_out(out: Path, overwrite: bool) -> None:
    """Refuse an existing output before any simulation is spent on it."""
    if overwrite or not out.exists():
        return
    if out.is_dir() and not any(out.iterdir()):
        return
    raise InputError(f"{out} exists; pass --overwrite to replace it or choose another --out")


def with_records(run: Run, request: LabRequest, tool_length_m: float | None = None) -> Run:
    """The run with what travels with it in its meta: the command's compensation record (for `check`), the cell
    it was made in and the tool it was made with (`tool_length_m`, the twin's declared tool's; None: as the lab
    wrote it)."""
    record = compensation_record(request)
    meta = {**run.meta, **({} if tool_length_m is None else {"tool_length_m": tool_length_m}),
            **({} if record is None else {"compensation": record.to_json()}),
            **({} if request.cell is None else {"cell": dict(request.cell)})}
    return replace(run, meta=meta)


def compensation_record(request: LabRequest) -> CompensationRecord | None:
    """The compensation record beside the request's commanded path, or None."""
    return read_record(request.commanded) if request.commanded is not None else None


def write_load_cases(out: Path, loads_n: np.ndarray, deflections_m: np.ndarray) -> None:
    """Write a load test's cases, base frame: loads [N] (m, 3) and the measured deflections [m] (m, 3) as mm."""
    columns = {"fx_n": loads_n[:, 0], "fy_n": loads_n[:, 1], "fz_n": loads_n[:, 2]}
    columns |= {f"d{a}_mm": 1e3 * deflections_m[:, i] for i, a in enumerate("xyz")}
    write_table(out, columns, formats={name: (".1f" if name.startswith("f") else ".5f") for name in columns})
