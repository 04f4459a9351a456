"""`sweep`: a Monte Carlo of the model's uncertainty (K_q, friction, sheet, force scale) replaying the compensated
(or the plain) ideal path once per parameter draw (`twin.apps.sweep.run_sweep`), and the distribution of the
residual it leaves: percentiles, timing, the uncertainty drawn from and every draw; optionally its figure.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twin.apps.sweep import SweepResult, run_sweep
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.inputs import HistoryDeclaration, ideal_path
from twin.errors import InputError
from twin.process.description import Process
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

    def __post_init__(self) -> None:
        for name, value, least in (("draws", self.draws, 1), ("seed", self.seed, 0), ("workers", self.workers, 1)):
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < least):
                raise InputError(f"{name} {value!r}: expected an integer >= {least}")


@dataclass(frozen=True)
class SweepReport(Report):
    """A sweep's distribution.

    Attributes:
        result: The residual of every draw, the uncertainty drawn from and the timing.
        figure: The distribution figure written, or None.
    """

    result: SweepResult
    figure: Path | None = None

    def lines(self) -> list[str]:
        """One line: draws, workers and speed; the RMS residual's median, 5-95 % band and the nominal model's."""
        summary = self.result.summary()
        rms = summary["rms_mm"]
        return [
            f"sweep: {summary['draws']} draws on {summary['workers']} workers in {summary['wall_s']:.1f} s "
            f"({summary['replays_per_s_per_core']:.1f} replays/s/core); RMS residual median {rms['p50']:.4f} mm "
            f"(5-95 %: {rms['p5']:.4f}-{rms['p95']:.4f} mm, nominal model {summary['nominal_rms_mm']:.4f} mm)"
        ]

    def record(self) -> dict[str, Any]:
        """`SweepResult.summary` (percentiles [mm], timing, the uncertainty, every draw) and the figure's path."""
        summary = self.result.summary()
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
        InputError: A bad history declaration, a force model the sweep cannot scale.
        DataFileError: A bad history, ideal path or calibration file (naming the file).
    """
    history, _ = request.history.load()
    path = ideal_path(request.ideal)
    start = time.perf_counter()

    def progress(done: int, total: int) -> None:
        filled = round(BAR_WIDTH * done / total)
        note(f"\rsweep [{'#' * filled}{'.' * (BAR_WIDTH - filled)}] {done}/{total} draws, "
             f"{time.perf_counter() - start:.1f} s" + ("\n" if done == total else ""))

    result = run_sweep(
        request.draws, spec=TwinSpec(process=Process(history=history)), seed=request.seed, workers=request.workers,
        calibration=request.calibration, path=path, compensate=not request.uncompensated, progress=progress,
        scheduler=request.scheduler,
    )
    figure = None
    if request.figure is not None:
        from twin.apps.sweep_figure import sweep_figure

        figure = sweep_figure(result, request.figure)
    return SweepReport(result, figure)
