"""`identify --forces` and `identify --springback`: the sheet's side of identification. The sheet force model's
level and shape fitted to a run's measured forces, and the springback (a factor on the elastic recovery F/k_unload
and the depth ratio kept) fitted to a run's part scan against its design, each on the twin the request resolves to
(`twin.analysis.resolve.resolve_spec`) and optionally written into a twin model file. The request is
`twin.apps.tasks.identify.IdentifyRequest`; `identify_task` dispatches here.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from twin.analysis.identify.forces import FITTED, WINDOW_S, ForceFit, fit_forces
from twin.analysis.identify.springback import SpringbackFit, fit_springback
from twin.analysis.resolve import resolve_spec
from twin.analysis.surface_check import read_target_mesh
from twin.apps.tasks.base import Note, Report, silent
from twin.errors import InputError
from twin.process.description import Process
from twin.process.part.match import check_same_part
from twin.runs.contact import require_forming_contact
from twin.runs.format import Run
from twin.runs.read import read_run
from twin.sim.model_file import write_model_file
from twin.sim.spec import TwinSpec

if TYPE_CHECKING:
    from twin.apps.tasks.identify import IdentifyRequest


@dataclass(frozen=True)
class ForcesReport(Report):
    """The sheet force model's constants fitted to a run's measured forces.

    Attributes:
        run_dir: The run.
        process: The process the fit ran on (its force model, material).
        fit: The fitted constants and the force rms before and after [N].
        model_written: The model file written, or None.
    """

    run_dir: Path
    process: Process
    fit: ForceFit
    model_written: Path | None = None

    def lines(self) -> list[str]:
        fit = self.fit
        values = ", ".join(f"{k} {v:.4g}" for k, v in fit.force_fit)
        return [
            f"identify --forces {self.run_dir} ({self.process.force_model} model, {fit.samples} samples): {values}; "
            f"force rms {fit.rms_before_n:.1f} N -> {fit.rms_after_n:.1f} N ({fit.windows} windows of {WINDOW_S:g} s)"
        ]

    def record(self) -> dict[str, Any]:
        fit = self.fit
        payload: dict[str, Any] = {
            "run": self.run_dir,
            "force_model": self.process.force_model,
            "process": {"material": self.process.material, "tensile_strength_mpa": self.process.tensile_strength_mpa},
            "force_fit": dict(fit.force_fit),
            "force_rms_before_n": fit.rms_before_n,
            "force_rms_after_n": fit.rms_after_n,
            "samples": fit.samples,
            "window_s": WINDOW_S,
            "windows": fit.windows,
            "evaluations": fit.evaluations,
            "at_bound": list(fit.at_bound),
        }
        if self.model_written is not None:
            payload["model_written"] = self.model_written
        return payload


@dataclass(frozen=True)
class SpringbackReport(Report):
    """The springback constants fitted to a run's part scan.

    Attributes:
        run_dir: The run.
        design: The part's design surface (STL).
        process: The process the fit ran on (its force model and the force constants it used).
        fit: The fitted constants, the scan's rms against the twin's part before and after [m], the registration.
        model_written: The model file written, or None.
    """

    run_dir: Path
    design: Path
    process: Process
    fit: SpringbackFit
    model_written: Path | None = None

    def lines(self) -> list[str]:
        fit = self.fit
        values = ", ".join(f"{k} {v:.4g}" for k, v in fit.springback_fit)
        return [
            f"identify --springback {self.run_dir} ({fit.points} scan points): {values}; scan against the twin's "
            f"part {1e3 * fit.rms_before_m:.3f} mm -> {1e3 * fit.rms_after_m:.3f} mm rms"
        ]

    def record(self) -> dict[str, Any]:
        fit = self.fit
        payload: dict[str, Any] = {
            "run": self.run_dir, "design": self.design, "force_model": self.process.force_model,
            "force_fit_used": dict(self.process.force_fit), "springback_fit": dict(fit.springback_fit),
            "scan_rms_before_mm": 1e3 * fit.rms_before_m, "scan_rms_after_mm": 1e3 * fit.rms_after_m,
            "points": fit.points, "evaluations": fit.evaluations, **fit.registration.summary_mm(),
        }
        if self.model_written is not None:
            payload["model_written"] = self.model_written
        return payload


def _spec(request: IdentifyRequest, measured: Run, note: Note) -> TwinSpec:
    """The twin of a sheet fit: the request's model, robot, process and force model over the run's."""
    return resolve_spec(model=request.model, robot=request.robot, run=measured, declaration=request.declaration,
                        force_model_name=request.force_model, p_sheet_m=measured.commanded.values, note=note,
                        cell=request.cell)


def forces_task(request: IdentifyRequest, note: Note = silent) -> ForcesReport:
    """Fit the force model to the measured forces of `request.forces`; `note` warns of a constant on its bound.

    Raises:
        InputError: Another robot than the run's, an unknown force model, a bad declaration.
        RunFormatError: A bad run folder, one without forces.csv (naming the file).
    """
    assert request.forces is not None
    measured = read_run(request.forces)
    require_forming_contact(measured, "`identify --forces`")
    spec = _spec(request, measured, note)
    fit = fit_forces(measured, spec.process)
    written = None
    if request.write_model is not None:
        fitted = spec.replace(process=replace(spec.process, force_fit=fit.force_fit))
        written = write_model_file(request.write_model, fitted, note=f"sheet forces fitted to {request.forces}",
                                   protect=[request.forces])
    bounds = {name: (low, high) for name, low, high in FITTED[spec.process.force_model]}
    for name in fit.at_bound:
        note(f"warning: {name} ended on its bound {bounds[name]} (its value is the bound's, not the cell's): the "
             f"{spec.process.force_model} model cannot take this run's force history; force rms left "
             f"{fit.rms_after_n:.1f} N")
    return ForcesReport(request.forces, spec.process, fit, written)


def springback_task(request: IdentifyRequest, note: Note = silent) -> SpringbackReport:
    """Fit the springback to the part scan of `request.springback` against `request.design`.

    Raises:
        InputError: A run without part_scan.csv, another robot than the run's, a bad declaration, a design or scan of
            another part than the run's command formed (`twin.process.part.match`).
        RunFormatError, DataFileError: A bad run folder or design file (naming it).
    """
    assert request.springback is not None and request.design is not None
    measured = read_run(request.springback, require_forces=False)
    if measured.part_scan is None:
        raise InputError(f"--springback {request.springback}: the run has no part_scan.csv (a scan of the formed "
                         "part is what shows its springback)")
    spec = _spec(request, measured, note)
    design = read_target_mesh(request.design)
    ran = f"the command of --springback {request.springback}"
    check_same_part(measured.commanded.values, design, f"--design {request.design}", path_what=ran,
                    tool_radius_m=spec.process.tool_radius_m)
    check_same_part(measured.commanded.values, measured.part_scan,
                    f"the scan {Path(request.springback) / 'part_scan.csv'}", path_what=ran,
                    tool_radius_m=spec.process.tool_radius_m)
    fit = fit_springback(measured, spec, design)
    written = None
    if request.write_model is not None:
        force_fit = tuple((dict(spec.process.force_fit) | dict(fit.springback_fit)).items())
        written = write_model_file(
            request.write_model, spec.replace(process=replace(spec.process, force_fit=force_fit)),
            note=f"springback fitted to the scan of {request.springback}",
            protect=[request.springback, request.design],
        )
    return SpringbackReport(request.springback, request.design, spec.process, fit, written)
