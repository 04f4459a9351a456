"""`sweep`: a Monte Carlo of the model's uncertainty (K_q, friction, sheet, force scale) replaying the compensated
(or the plain) ideal path once per parameter draw (`twin.apps.sweep.run_sweep`), and the distribution of the
residual it leaves: percentiles, timing, the uncertainty drawn from and every draw; optionally its figure. The
nominal twin is the one its request resolves to (`twin.analysis.resolve.resolve_spec`: a model file, a robot, a
declared process); the draws vary the table field's sensitivities, so its force model must be the table.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twin.analysis.resolve import AUTO, resolve_spec
from twin.apps.sweep import SweepResult, check_draws, run_sweep
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.inputs import HistoryDeclaration, ideal_path
from twin.errors import InputError
from twin.process.process_file import ProcessDeclaration, process_record
from twin.sim.spec import TwinSpec

BAR_WIDTH = 30
"""Characters of the progress bar."""


@dataclass(frozen=True)
class SweepRequest:
    """What to sweep.

    Attributes:
        draws: Parameter sets to replay (>= 1).
        seed: Seed of the draws (>= 0).
        workers: Worker processes (>= 1), or None for every usable core.
        scheduler: A Dask distributed scheduler's address to run the draws on, or None for local processes.
        calibration: A calibration JSON with 'parameters' and 'sigma' (`tx200-twin calibrate`), or None for the
            model's values with the relative sigma of `twin.apps.uncertainty.DEFAULT_RELATIVE_SIGMA`.
        uncompensated: Replay the ideal path itself, not its compensation.
        history: The FE force history of the nominal twin.
        ideal: The ideal path U_ID (CSV t_s,x_mm,y_mm,z_mm), or None for the thesis groove.
        figure: Where to write the distribution figure (PNG), or None.
        model: A twin model file (`learn --write-model`, `discrepancy --model-out`): the nominal twin, or None for
            the default cell.
        robot: A robot name or description file, or None (the model file's, else the default).
        declaration: The process declared over the model's (a process file, flags); its force model, if it
            names one, must be the table.

    Raises:
        InputError: A count out of range; more draws than `twin.apps.sweep.check_draws` allows (before any
            allocation).
        cell: A `--cell` file's record (`CellDeclaration.record`): its tool is the twin's (`resolve_spec`).
    """

    draws: int = 200
    seed: int = 0
    workers: int | None = None
    scheduler: str | None = None
    calibration: Path | None = None
    uncompensated: bool = False
    history: HistoryDeclaration = field(default_factory=HistoryDeclaration)
    ideal: Path | None = None
    figure: Path | None = None
    model: Path | None = None
    robot: str | Path | None = None
    declaration: ProcessDeclaration = field(default_factory=ProcessDeclaration)
    cell: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        for name, value, least in (("draws", self.draws, 1), ("seed", self.seed, 0), ("workers", self.workers, 1)):
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < least):
                raise InputError(f"{name} {value!r}: expected an integer >= {least}")
        check_draws(self.draws)

    def spec(self, history: Any, p_sheet_m: Any, note: Note = silent) -> TwinSpec:
        """The nominal twin (`resolve_spec`) for the ideal path `p_sheet_m` [m] and the declared FE `history`.

        Raises:
            InputError: Its force model is not the table field (the sweep draws the table's sensitivities).
        """
        spec = resolve_spec(cell=self.cell, model=self.model, robot=self.robot, declaration=self.declaration,
                            force_model_name=AUTO, history=history, p_sheet_m=p_sheet_m, note=note)
        if spec.process.force_model != "table":
            raise InputError(f"the sweep draws the 'table' force field's sensitivities (k_unload, k_load) and force "
                             f"scale; the twin's force model resolves to {spec.process.force_model!r} for this "
                             "path and process: sweep the FE history's own path (--ideal on the groove) or declare "
                             "force_model = \"table\" in --process")
        return spec


@dataclass(frozen=True)
class SweepReport(Report):
    """A sweep's distribution.

    Attributes:
        result: The residual of every draw, the uncertainty drawn from and the timing.
        figure: The distribution figure written, or None.
        spec: The nominal twin swept, or None.
    """

    result: SweepResult
    figure: Path | None = None
    spec: TwinSpec | None = None

    def lines(self) -> list[str]:
        """One line: draws, workers and speed; the RMS residual's median, 5-95 % band and the nominal model's."""
        summary = self.result.summary()
        rms = summary["rms_mm"]
        return [
            f"sweep: {summary['draws']} draws on {summary['workers']} workers in {summary['wall_s']:.1f} s "
            f"({summary['replays_per_s_per_core']:.1f} replays/s/core); RMS residual median {rms['p50']:.4f} mm "
            f"(5-95 %: {rms['p5']:.4f}-{rms['p95']:.4f} mm, nominal model {summary['nominal_rms_mm']:.4f} mm)"
            + ("" if self.spec is None else f"; twin: robot {self.spec.robot.name}, {self.spec.process.material}, "
               f"{1e3 * self.spec.process.thickness_m:g} mm sheet")
        ]

    def record(self) -> dict[str, Any]:
        """`SweepResult.summary` (percentiles [mm], timing, the uncertainty, every draw), the twin's robot and
        process, and the figure's path."""
        summary = self.result.summary()
        if self.spec is not None:
            summary["robot"] = self.spec.robot.name
            summary["process"] = {**process_record(self.spec.process), "force_model": self.spec.process.force_model}
        if self.figure is not None:
            summary["figure"] = str(self.figure)
        return summary


def sweep_task(request: SweepRequest, note: Note = silent) -> SweepReport:
    """Run the sweep.

    Args:
        request: What to sweep.
        note: Receives the progress bar after each finished draw, as the text to write as is: it starts with a
            carriage return (it redraws the bar in place) and ends with a newline only after the last draw.

    Raises:
        InputError: A bad history declaration, a force model the sweep cannot scale, a robot of another number
            of joints than the sweep's parameters.
        DataFileError: A bad history, ideal path, model or calibration file (naming the file).
    """
    history, _ = request.history.load()
    path = ideal_path(request.ideal)
    spec = request.spec(None if request.history.path is None else history, path.p_sheet_m,
                        note=lambda text: note(text + "\n"))
    start = time.perf_counter()

    def progress(done: int, total: int) -> None:
        filled = round(BAR_WIDTH * done / total)
        note(f"\rsweep [{'#' * filled}{'.' * (BAR_WIDTH - filled)}] {done}/{total} draws, "
             f"{time.perf_counter() - start:.1f} s" + ("\n" if done == total else ""))

    result = run_sweep(
        request.draws, spec=spec, seed=request.seed, workers=request.workers,
        calibration=request.calibration, path=path, compensate=not request.uncompensated, progress=progress,
        scheduler=request.scheduler,
    )
    figure = None
    if request.figure is not None:
        from twin.apps.sweep_figure import sweep_figure

        figure = sweep_figure(result, request.figure)
    return SweepReport(result, figure, spec)
