"""`place`: where to put the sheet for the least predicted error of a part: candidate placements (the sheet's
origin and yaw in the robot base) drawn in a box around the twin's own, screened by a linear compliance model,
reach and joint margins, the best few confirmed by simulating the twin (`twin.analysis.placement_search`), on local
processes or a Dask cluster; with the map of the screened error if asked.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twin.analysis.placement_search import PlacementSearch, SearchBox, describe, search_placement
from twin.analysis.resolve import AUTO, resolve_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.inputs import ideal_path
from twin.base.jobs import scheduler_address
from twin.errors import InputError
from twin.process.process_file import ProcessDeclaration

Progress = Callable[[str, int, int], None]
"""Called with (stage, done, total) as the search's jobs complete; stage "screen" or "confirm"."""


@dataclass(frozen=True)
class PlaceRequest:
    """What to place, and how to search.

    Attributes:
        ideal: The part's ideal path U_ID (CSV t_s, x_mm, y_mm, z_mm), or None for the groove.
        model: A model file (effects, K_q, process, placement; the box's centre), or None for the default cell.
        force_model: A registered force model, or "auto" (`twin.analysis.resolve.choose_force_model`).
        declaration: The process declared over the model's (a process file, flags).
        robot: A robot name or description file, or None (the model's, else the default).
        candidates: Candidate placements screened, >= 1.
        confirm: Best screened candidates simulated by the twin, at most `candidates`.
        seed: Seed of the candidates (a Latin hypercube).
        box_mm: Half-widths of the origin's box along base x, y, z [mm], >= 0.
        yaw_range_deg: Half-range of the yaw [deg], in [0, 180].
        joint_margin_deg: Smallest distance to a joint limit a feasible placement keeps [deg], >= 0.
        workers: Local worker processes, or None for every usable core.
        scheduler: The address of a Dask distributed scheduler to run the jobs on, or None (local processes).
        figure: The map of the screened error to write (PNG), or None.
        cell: A `--cell` file's record (`CellDeclaration.record`): its tool is the twin's (`resolve_spec`).
    """

    ideal: Path | None = None
    model: Path | None = None
    force_model: str = AUTO
    declaration: ProcessDeclaration = field(default_factory=ProcessDeclaration)
    robot: str | Path | None = None
    candidates: int = 512
    confirm: int = 5
    seed: int = 0
    box_mm: tuple[float, float, float] = (300.0, 400.0, 100.0)
    yaw_range_deg: float = 180.0
    joint_margin_deg: float = 5.0
    workers: int | None = None
    scheduler: str | None = None
    figure: Path | None = None
    cell: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        if any(v < 0 for v in self.box_mm) or not 0.0 <= self.yaw_range_deg <= 180.0 or self.joint_margin_deg < 0:
            raise InputError(f"--box-mm {' '.join(f'{v:g}' for v in self.box_mm)} --yaw-range-deg "
                             f"{self.yaw_range_deg:g} --joint-margin-deg {self.joint_margin_deg:g}: expected "
                             "half-widths >= 0 mm, a yaw half-range in [0, 180] deg and a margin >= 0 deg")
        if self.scheduler is not None:
            scheduler_address(self.scheduler)  # its form, before any work; `Jobs` connects later
        if self.confirm > self.candidates:
            raise InputError(f"--confirm {self.confirm} > --candidates {self.candidates}: expected at most the "
                             "candidates")

    def box(self) -> SearchBox:
        """The candidate box [m, rad]."""
        return SearchBox(half_width_m=(self.box_mm[0] / 1e3, self.box_mm[1] / 1e3, self.box_mm[2] / 1e3),
                         half_yaw_rad=math.radians(self.yaw_range_deg))


@dataclass(frozen=True)
class PlaceReport(Report):
    """The placement search's result.

    Attributes:
        result: The candidates, their screens and simulations, the default and the best.
        figure: The map written, or None.
    """

    result: PlacementSearch
    figure: str | None = None

    def lines(self) -> list[str]:
        result, summary = self.result, self.result.summary()
        d, skipped = summary["default"], ", ".join(f"{k} {v}" for k, v in summary["infeasible"].items() if v)
        lines = [f"place: {summary['feasible']} of {summary['candidates']} candidates feasible"
                 f"{f' (skipped: {skipped})' if skipped else ''}, on {summary['where']} in "
                 f"{result.timings_s['total']:.1f} s",
                 f"  default  {describe(result.default_row)}: simulated rms {_mm(d['simulated_rms_mm'])}, "
                 f"max {_mm(d['simulated_max_mm'])} (screened rms {_mm(d['screened_rms_mm'])}, "
                 f"{d['screened_status']})"]
        if result.best is None:
            return [*lines, "  no confirmed candidate is feasible along the whole path"]
        b = summary["best"]
        return [*lines, f"  best     {describe(result.rows[result.best])}: simulated rms {_mm(b['simulated_rms_mm'])}, "
                        f"max {_mm(b['simulated_max_mm'])} (screened rms {_mm(b['screened_rms_mm'])}), "
                        f"{summary['best_over_default_rms']:.2f}x the default's rms"]

    def record(self) -> dict[str, Any]:
        summary = self.result.summary()
        return summary if self.figure is None else {**summary, "figure": self.figure}


def place_task(request: PlaceRequest, note: Note = silent, *, progress: Progress | None = None) -> PlaceReport:
    """Search the sheet's placement for the request's part on its twin (`twin.analysis.resolve.resolve_spec`).

    Args:
        request: What to place, and how to search.
        note: Where to say a choice the user may not expect.
        progress: Called with (stage, done, total) as the jobs complete (the CLI: a progress line), or None.

    Raises:
        InputError: A bad scheduler address, a bad declaration (naming the option); no candidate placement
            reaches the part along its whole path (saying what was tried).
        UnreachableError, SingularityError: The path is not feasible at the default placement.
        DataFileError: A bad path or model file (naming the file).
    """
    ideal = ideal_path(request.ideal)
    spec = resolve_spec(cell=request.cell, model=request.model, robot=request.robot, declaration=request.declaration,
                        force_model_name=request.force_model, p_sheet_m=ideal.p_sheet_m, note=note)
    result = search_placement(
        ideal, spec, candidates=request.candidates, confirm=request.confirm, seed=request.seed, box=request.box(),
        joint_margin_rad=math.radians(request.joint_margin_deg), workers=request.workers,
        scheduler=request.scheduler, progress=progress,
    )
    if result.best is None:  # nothing written: no JSON, no figure
        raise _no_placement(request, result)
    figure = None
    if request.figure is not None:
        from twin.viz.placement_figure import placement_figure

        figure = str(placement_figure(result, request.figure))
    return PlaceReport(result, figure)


def _no_placement(request: PlaceRequest, result: PlacementSearch) -> InputError:
    """The error of a search that found no feasible placement: what was tried and why each candidate failed."""
    summary = result.summary()
    skipped = ", ".join(f"{k} {v}" for k, v in summary["infeasible"].items() if v) or "none"
    confirmed = [c["simulated_status"] for c in summary["confirmed"]]
    after = (f"; the {len(confirmed)} best confirmed by the twin failed along the whole path "
             f"({', '.join(dict.fromkeys(confirmed))})" if confirmed else "")
    part = "the groove" if request.ideal is None else f"--ideal {request.ideal}"
    return InputError(
        f"no placement reaches the part ({part}): {summary['feasible']} of {summary['candidates']} candidates "
        f"feasible (skipped: {skipped}){after}; tried --candidates {request.candidates} --seed {request.seed} in "
        f"--box-mm {' '.join(f'{v:g}' for v in request.box_mm)} --yaw-range-deg {request.yaw_range_deg:g} around "
        f"{describe(result.default_row)} with --joint-margin-deg {request.joint_margin_deg:g}; expected a part the "
        "robot reaches: widen --box-mm or --yaw-range-deg, lower --joint-margin-deg, draw more --candidates, or "
        "centre the search elsewhere (a --model with another placement)")


def _mm(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.3f} mm"
