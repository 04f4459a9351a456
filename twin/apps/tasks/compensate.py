"""`compensate`: the ideal path compensated offline, by the formula of Eq. 4.28 with an identified stiffness or by
iterating the twin (`twin.analysis.compensate`), written as a command (commanded.csv format) with the record of the
forces it assumed (`CMD.compensation.json`, what `check` names a gain's cause from); with a design surface
(`target_stl`), the part to the design instead (`twin.apps.tasks.compensate_part`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.analysis.compensate import (
    TWIN_MAX_ITER,
    TWIN_TOL_M,
    Compensation,
    compensate_formula,
    compensate_twin,
    compliance_from_stiffness,
    gain_of,
)
from twin.analysis.compensation_record import CompensationRecord, write_record
from twin.analysis.off_sheet import off_sheet_warning
from twin.analysis.resolve import AUTO, resolve_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.inputs import HistoryDeclaration, ideal_path
from twin.base.jsonio import read_json
from twin.errors import DataFileError, ExtrapolationWarning, InputError
from twin.process.fe.load import ForceHistory
from twin.process.force.registry import build_force_field
from twin.process.force.span import warn_outside_span
from twin.process.process_file import ProcessDeclaration, process_record
from twin.process.toolpath.groove import ToolPath
from twin.process.toolpath.placement import Placement
from twin.runs.format import Stream
from twin.runs.write import write_path_csv
from twin.sim.spec import TwinSpec

if TYPE_CHECKING:  # the dynamic twin (MuJoCo) loads only when --dynamic runs
    from twin.analysis.compensate_dynamic import DynamicCompensation

METHODS = ("formula", "twin")
LEARN_AT = ("twin", "formed", "tip")
SYMMETRY_TOLERANCE = 0.25  # |K - K^T| / max|K| allowed: Method 2 on a noisy lab run fits up to ~0.15
GAIN_WARNING = 0.02  # a gain further than this from 1 is warned about, with its diagnosis [-]


@dataclass(frozen=True)
class CompensateRequest:
    """What to compensate, and how.

    Attributes:
        method: "formula" (Eq. 4.28 with `stiffness`) or "twin" (iterating the twin).
        out: The command to write (commanded.csv format; its record goes beside it).
        stiffness: A JSON file with `k_r_n_per_mm` (2x2 x-z or 3x3) [N/mm]; "formula" only.
        model: A model file (effects, K_q, process), or None for the default cell.
        history: The FE force history and its symmetry (none: the shipped stand-in).
        ideal: The ideal path U_ID (CSV t_s, x_mm, y_mm, z_mm), or None for the groove.
        force_model: A registered force model, or "auto" (`twin.analysis.resolve.choose_force_model`).
        declaration: The process declared over the model's (a process file, flags).
        robot: A robot name or description file, or None (the model's, else the default).
        placement: The sheet's placement in the twin, or None (the model's).
        tol_mm: "twin": stop when the rms residual is within this [mm], > 0.
        max_iter: "twin": iteration limit, >= 1.
        target_stl: A design surface (STL, PLY or OBJ; sheet frame, mm): compensate the part to it (twin only).
        part_iterations: Outer iterations on the part.
        learn_from: The last part's run (its command and part scan): learn the next command from its scan.
        learn_at: How the scan's error is learned: "twin", "formed" or "tip" (`twin.analysis.scan_learning`).
        learn_gain: Learning gain, in (0, 1].
        learn_smoothing_mm: Gaussian smoothing of the learned error [mm], > 0.
        figure: Deviation maps from the design to write (PNG), or None; with `target_stl` only.
        rrd: A rerun recording of the part's iterations to write, or None; with `target_stl` only.
        cell: A `--cell` file's record (`CellDeclaration.record`): its tool is the twin's (`resolve_spec`).
        dynamic: "twin": then iterate the command on the dynamic twin under the model's learned servo
            (`twin.analysis.compensate_dynamic`).
    """

    method: str
    out: Path
    stiffness: Path | None = None
    model: Path | None = None
    history: HistoryDeclaration = field(default_factory=HistoryDeclaration)
    ideal: Path | None = None
    force_model: str = AUTO
    declaration: ProcessDeclaration = field(default_factory=ProcessDeclaration)
    robot: str | Path | None = None
    placement: Placement | None = None
    tol_mm: float = 1e3 * TWIN_TOL_M
    max_iter: int = TWIN_MAX_ITER
    target_stl: Path | None = None
    part_iterations: int = 2
    learn_from: Path | None = None
    learn_at: str = "twin"
    learn_gain: float = 1.0
    learn_smoothing_mm: float = 2.0
    figure: Path | None = None
    rrd: Path | None = None
    cell: dict[str, Any] | None = None
    dynamic: bool = False

    def __post_init__(self) -> None:
        for option, value, valid in (("--method", self.method, METHODS), ("--learn-at", self.learn_at, LEARN_AT)):
            if value not in valid:
                raise InputError(f"{option} {value!r}: expected one of {', '.join(valid)}")
        if self.dynamic and (self.method != "twin" or self.target_stl is not None):
            raise InputError(f"--dynamic iterates the path on the dynamic twin: it needs --method twin and no "
                             f"--target-stl (got --method {self.method}"
                             f"{'' if self.target_stl is None else ' --target-stl ' + str(self.target_stl)})")
        if self.target_stl is not None:
            self._check_part()
            return
        for option, given in (("--learn-from", self.learn_from), ("--figure", self.figure), ("--rrd", self.rrd)):
            if given is not None:
                raise InputError(f"{option} needs --target-stl DESIGN (the surface the part is measured against); "
                                 f"got {option} {given} without it")
        if self.method == "twin" and not (self.tol_mm > 0 and self.max_iter >= 1):
            raise InputError(f"--tol-mm {self.tol_mm} and --max-iter {self.max_iter}: expected > 0 and >= 1")

    def _check_part(self) -> None:
        """The part's options (`target_stl`)."""
        if self.method != "twin":
            raise InputError("--target-stl needs --method twin (the twin predicts the part after unclamping)")
        if self.learn_from is not None and not (0.0 < self.learn_gain <= 1.0 and self.learn_smoothing_mm > 0.0):
            raise InputError(f"--learn-gain {self.learn_gain:g} must be in (0, 1] and --learn-smoothing-mm "
                             f"{self.learn_smoothing_mm:g} > 0")
        if self.learn_from is not None and self.learn_at == "twin" and self.ideal is None:
            raise InputError("--learn-at twin needs --ideal PART.csv (the part's tool path: the twin's part "
                             "compensation keeps its x-y), or --learn-at formed|tip (the last command moved)")

    def inputs(self) -> list[Path]:
        """The files it reads (which its outputs must not replace)."""
        given = (self.stiffness, self.model, self.history.path, self.ideal, self.target_stl, self.learn_from)
        return [p for p in given if p is not None]

    def spec(self, p_sheet_m: np.ndarray, history: ForceHistory | None = None, note: Note = silent) -> TwinSpec:
        """The twin it compensates with (`twin.analysis.resolve.resolve_spec`) for the path `p_sheet_m` [m]."""
        return resolve_spec(cell=self.cell, model=self.model, robot=self.robot, declaration=self.declaration,
                            force_model_name=self.force_model, placement=self.placement, history=history,
                            p_sheet_m=p_sheet_m, note=note)


@dataclass(frozen=True)
class CompensateReport(Report):
    """A compensated path and what the twin predicts of it.

    Attributes:
        request: What was compensated.
        spec: The twin it was compensated with.
        history: The FE force history as declared.
        compensation: The compensated command and its iterations.
        compliance_m_per_n: The compliance its gain is measured with [m/N], shape (2, 2) or (3, 3).
        predicted_residual_m: The twin's predicted tip minus U_ID for the command [m], shape (n, 3).
        gain: The compensation gain against the physical reference forces [-] (1: right).
        gain_diagnosis: The gain and its cause in words (`twin.analysis.check.diagnose_gain`).
        record_file: The compensation record written beside the command.
        dynamic: With `dynamic`: the dynamic twin's iteration (its start is the quasi-static compensation).
    """

    request: CompensateRequest
    spec: TwinSpec
    history: ForceHistory
    compensation: Compensation
    compliance_m_per_n: np.ndarray
    predicted_residual_m: np.ndarray
    gain: float
    gain_diagnosis: str
    record_file: Path
    dynamic: DynamicCompensation | None = None

    def lines(self) -> list[str]:
        r = self.record()
        lines = [f"compensate ({self.request.method}): gain {self.gain:.3f}, {r['iterations']} iteration(s), "
                 f"predicted residual rms {r['predicted_residual_rms_mm']:.4f} mm, max correction "
                 f"{r['correction_max_mm']:.2f} mm -> {self.request.out}"]
        if not self.compensation.converged:
            which = "twin" if self.dynamic is None else "dynamic twin's"
            lines.append(f"note: the {which} iteration stopped at {r['predicted_residual_rms_mm']:.4f} mm rms (max "
                         f"{r['predicted_residual_max_mm']:.3f} mm, where joint friction flips: reversals, corners, "
                         "stick-slip); the best command is written")
        if self.dynamic is not None:
            history = r["residual_rms_per_iteration_mm"]  # the dynamic twin's, the first on the quasi-static command
            lines.append(f"dynamic twin: rms {history[0]:.4f} mm on the quasi-static command -> "
                         f"{r['predicted_residual_rms_mm']:.4f} mm in {len(history) - 1} iteration(s) (learning "
                         f"filter sigma {r['dynamic']['learning_filter_ms']:.1f} ms); predicted")
        if abs(self.gain - 1.0) > GAIN_WARNING:
            lines.append(f"warning: {self.gain_diagnosis}")
        return lines

    def record(self) -> dict[str, Any]:
        comp, norm = self.compensation, np.linalg.norm(self.predicted_residual_m, axis=1)
        return {
            "method": self.request.method,
            "out": self.request.out,
            "gain": self.gain,
            "gain_diagnosis": self.gain_diagnosis,
            "record": self.record_file,
            "iterations": comp.iterations,
            "converged": comp.converged,
            "residual_rms_per_iteration_mm": [1e3 * h for h in comp.history_m],
            "predicted_residual_rms_mm": 1e3 * float(np.sqrt(np.mean(norm**2))),
            "predicted_residual_max_mm": 1e3 * float(np.max(norm)),
            "correction_max_mm": 1e3 * float(np.max(np.linalg.norm(comp.correction_m, axis=1))),
            "compliance_mm_per_kn": 1e6 * self.compliance_m_per_n,
            "history": {"file": self.history.source, "symmetry": self.history.symmetry},
            "force_model": self.spec.process.force_model,
            "process": process_record(self.spec.process),
            "effects": dict(self.spec.effects.values),
            "dynamic": None if self.dynamic is None else {
                "servo": self.dynamic.servo.to_json(),
                "quasi_static_rms_per_iteration_mm": [1e3 * h for h in self.dynamic.quasi_static.history_m],
                "learning_filter_ms": 1e3 * self.dynamic.smoothing_s},
        }


def compensate_task(request: CompensateRequest, note: Note = silent) -> Report:
    """Compensate the ideal path (or, with `target_stl`, the part) and write the command and its record.

    Returns:
        A `CompensateReport`; with `target_stl`, a `twin.apps.tasks.compensate_part.PartReport`.

    Raises:
        InputError: "formula" without a stiffness file, a bad declaration (naming the option).
        DataFileError: A bad stiffness, history, ideal path or model file (naming the file).
    """
    if request.target_stl is not None:
        from twin.apps.tasks.compensate_part import compensate_part_task

        return compensate_part_task(request, note)
    from twin.analysis.check import diagnose_gain  # the check loads the twin
    from twin.sim.compiled.rigid import rigid_forces  # numba: only when a compensation runs

    declared, reference = request.history.load()
    ideal = ideal_path(request.ideal)
    spec = request.spec(ideal.p_sheet_m, declared, note)
    if request.dynamic and spec.dynamic_servo is None:
        raise InputError(f"--dynamic needs the dynamic twin's servo, learned into a model file (`tx200-twin learn RUN "
                         f"--dynamic --write-model MODEL`); {request.model or 'the default model'} carries no "
                         "dynamic_servo")
    warn_outside_span(spec.process, ideal.p_sheet_m, f"the ideal path {request.ideal or '(the groove)'}")
    f_reference = rigid_forces(build_force_field(spec.process, reference), ideal)
    comp, c_r, predicted, f_used, dynamic = _compensate(request, spec, ideal, declared)
    if (sentence := off_sheet_warning(comp.t_s, ideal.p_sheet_m, f_used)) is not None:
        warnings.warn(sentence, ExtrapolationWarning, stacklevel=2)
    gain = gain_of(comp, f_reference, c_r)
    # an FE history's symmetry is evidence only where its forces were used (the table model; the formula's K_R)
    uses_history = request.method == "formula" or spec.process.force_model == "table"
    history_file = None if request.history.path is None or not uses_history else str(request.history.path)
    record = CompensationRecord(request.method, comp.t_s, f_used, declared.symmetry if uses_history else None,
                                declared.column_symmetry if uses_history else None, history_file)
    write_command(request.out, comp.t_s, comp.p_cmd_sheet_m, request.inputs())
    record_file = write_record(request.out, record)
    return CompensateReport(request, spec, declared, comp, c_r, predicted, gain,
                            diagnose_gain(gain, record, ideal.t_s, f_reference), record_file, dynamic)


def _compensate(
    request: CompensateRequest, spec: TwinSpec, ideal: ToolPath, declared: ForceHistory
) -> tuple[Compensation, np.ndarray, np.ndarray, np.ndarray, DynamicCompensation | None]:
    """The compensation of the request's method, the compliance its gain is measured with [m/N], the twin's
    predicted residual of the command [m], shape (n, 3), the forces it assumed at each sample [N], (n, 3), and with
    `dynamic` the dynamic twin's iteration."""
    twin = spec.build()
    if request.method == "formula":
        if request.stiffness is None:  # here, not in the request: a bad ideal path or model is named first
            raise InputError("--method formula needs --stiffness FILE with k_r_n_per_mm (e.g. an identify output)")
        c_r = compliance_from_stiffness(read_stiffness(request.stiffness))
        from twin.sim.compiled.rigid import rigid_forces  # the twin above loaded numba
        f_ideal = rigid_forces(build_force_field(spec.process, declared), ideal)
        comp = compensate_formula(ideal.t_s, ideal.p_sheet_m, f_ideal, c_r)
        return comp, c_r, twin.simulate(comp.t_s, comp.p_cmd_sheet_m).p_sheet_m - ideal.p_sheet_m, f_ideal, None
    comp = compensate_twin(ideal.t_s, ideal.p_sheet_m, twin, tol_m=1e-3 * request.tol_mm, max_iter=request.max_iter)
    dynamic = None
    if request.dynamic:
        from twin.analysis.compensate_dynamic import compensate_dynamic

        assert spec.dynamic_servo is not None  # compensate_task refused a model without one
        dynamic = compensate_dynamic(ideal.t_s, ideal.p_sheet_m, twin, spec.dynamic_servo, start=comp,
                                     tol_m=1e-3 * request.tol_mm)
        comp = dynamic.compensation
    assert comp.predicted_residual_m is not None and comp.predicted_force_n is not None
    # the forces the twin predicts for its command (the simulation that gave its residual)
    from twin.robot.tool_bending import bending_compliance_at

    q_home = twin.kinematics.q_home  # the joints' compliance and the tool's own bending (`twin.robot.tool_bending`)
    c_r = twin.kinematics.compliance(q_home) + bending_compliance_at(twin.model, twin.robot, q_home)
    return comp, c_r, comp.predicted_residual_m, comp.predicted_force_n, dynamic


def read_stiffness(path: Path) -> np.ndarray:
    """The Cartesian stiffness K_R of a JSON file's `k_r_n_per_mm` (2x2 x-z or 3x3) [N/m].

    Raises:
        DataFileError: No such key, another shape, non-finite values, not symmetric within `SYMMETRY_TOLERANCE`
            or not positive definite (naming the file).
    """
    payload = read_json(path)
    if "k_r_n_per_mm" not in payload:
        raise DataFileError(path, f"missing key 'k_r_n_per_mm'; found {sorted(payload)}")
    k = np.asarray(payload["k_r_n_per_mm"], dtype=float)
    if k.shape not in ((2, 2), (3, 3)):
        raise DataFileError(path, f"k_r_n_per_mm has shape {k.shape}, expected 2x2 (x-z) or 3x3 [N/mm]")
    if not np.all(np.isfinite(k)):
        raise DataFileError(path, f"k_r_n_per_mm holds {k.tolist()}: expected finite numbers [N/mm]")
    asymmetry = float(np.max(np.abs(k - k.T))) / max(float(np.max(np.abs(k))), 1e-300)
    if asymmetry > SYMMETRY_TOLERANCE:
        raise DataFileError(path, f"k_r_n_per_mm is not symmetric: max |K - K^T| is {asymmetry:.3g} of max |K|, "
                                  f"expected a stiffness matrix symmetric within {SYMMETRY_TOLERANCE:g}")
    smallest = float(np.linalg.eigvalsh(0.5 * (k + k.T))[0])
    if smallest <= 0.0:
        raise DataFileError(path, f"k_r_n_per_mm is not positive definite (smallest eigenvalue {smallest:.4g} N/mm): "
                                  "a stiffness pushes back; expected all eigenvalues > 0")
    return 1e3 * k


def write_command(out: Path, t_s: np.ndarray, p_cmd_sheet_m: np.ndarray, protect: list[Path]) -> None:
    """Write a command in the path CSV format (`twin.runs.write.write_path_csv`), never over `protect`."""
    write_path_csv(Stream(np.asarray(t_s, dtype=float), np.asarray(p_cmd_sheet_m, dtype=float)), out, protect=protect)
