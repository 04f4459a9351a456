"""`calibrate`: the twin's free physical parameters (the joint stiffness K_q, the joint friction, the sheet's
sensitivities) fitted by least squares to the thesis's measured numbers (`twin.analysis.calibration.fit`), and on
request the leave-one-out refits that predict each target from the others (`twin.analysis.calibration.loo`).
About 1-4 minutes on 2 cores, and 3 more for the leave-one-out refits.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from twin.analysis.calibration.fit import PARAMETERS, Calibration, calibrate
from twin.analysis.calibration.loo import LeaveOneOut, leave_one_out
from twin.analysis.calibration.targets import TARGETS
from twin.apps.tasks.base import Note, Report, silent

#: A progress note every this many twin evaluations.
PROGRESS_EVERY = 10


@dataclass(frozen=True)
class CalibrateRequest:
    """What to calibrate.

    Attributes:
        loo: Also refit once per target without it and predict it (leave-one-out; about 3 minutes on 2 cores).
    """

    loo: bool = False


@dataclass(frozen=True)
class CalibrateReport(Report):
    """The calibration, and the leave-one-out predictions when asked for.

    Attributes:
        calibration: The fitted parameters (SI), their 1σ, the targets measured on the calibrated twin.
        loo: The leave-one-out refits, or None.
    """

    calibration: Calibration
    loo: LeaveOneOut | None = None

    @property
    def degrees_of_freedom(self) -> int:
        """Targets less parameters."""
        return len(TARGETS) - len(PARAMETERS)

    def lines(self) -> list[str]:
        cal = self.calibration
        lines = [f"calibration: {cal.evaluations} evaluations, reduced chi2 {cal.chi2_reduced:.2f} ({len(TARGETS)} "
                 f"targets, {len(PARAMETERS)} parameters: {self.degrees_of_freedom} degrees of freedom)"]
        lines += [f"  {name:18s} {cal.values[name]:12.5g} ± {cal.sigma[name]:.2g}" for name in PARAMETERS]
        lines.append("  target             thesis       twin   (twin-thesis)/sigma")
        lines += [f"  {row['target']:16s} {row['thesis']:9.3f} {row['twin']:10.3f}   {row['normalised']:+.2f}"
                  for row in cal.residuals()]
        if self.loo is not None:
            lines.append("  target             thesis     fitted  predicted (left out)")
            for p in self.loo.predictions:
                held = f"   {', '.join(p.sole)} held at its prior: not a prediction" if p.sole else ""
                lines.append(f"  {p.target:16s} {p.thesis:9.3f} {p.fitted:10.3f} {p.predicted:10.3f}{held}")
        return lines

    def record(self) -> dict[str, Any]:
        cal, measured = self.calibration, self.calibration.measurements
        return {
            "targets_count": len(TARGETS),
            "degrees_of_freedom": self.degrees_of_freedom,
            "parameters": cal.values,
            "sigma": cal.sigma,
            "start": cal.start,
            "chi2_reduced": cal.chi2_reduced,
            "evaluations": cal.evaluations,
            "targets": cal.residuals(),
            "k_r1_n_per_mm": measured.k_r1_n_per_mm,
            "cr1_mm_per_kn": measured.cr1_mm_per_kn,
            "k_r2_n_per_mm": measured.k_r2_n_per_mm,
            "cr2_mm_per_kn": measured.cr2_mm_per_kn,
            "method2_force_drop": measured.force_drop,
            **({} if self.loo is None else {"leave_one_out": [p._asdict() for p in self.loo.predictions]}),
        }


def calibrate_task(request: CalibrateRequest, note: Note = silent) -> CalibrateReport:
    """Calibrate the twin to the thesis's measurements; `note` gets the progress (every `PROGRESS_EVERY`
    evaluations, each leave-one-out refit)."""

    def progress(count: int, cost: float) -> None:
        if count % PROGRESS_EVERY == 0:
            note(f"  {count} twin evaluations, cost {cost:.3f}")

    cal = calibrate(progress=progress)
    loo = leave_one_out(progress=lambda name: note(f"  leave-one-out: refit without {name}")) if request.loo else None
    return CalibrateReport(cal, loo)
