"""`identify`: the robot's Cartesian stiffness K_R by thesis Method 1 (static load cases) or Method 2 (a nominal
run), with the joint stiffness K_q it implies (thesis §4.2); a request naming `forces` or `springback` fits the
sheet instead (`twin.apps.tasks.identify_sheet`). One request says which, and `identify_task` dispatches on it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.identify.cartesian import KrFit, fit_kr_load_cases, load_cases_csv
from twin.analysis.identify.joint import KqFit
from twin.analysis.identify.method2 import MIN_FORCE_SPAN, Method2Result, method2
from twin.analysis.identify.rollouts import (
    KqRolloutFit,
    kq_from_run,
    kq_from_stiffness,
    write_joint_stiffness,
)
from twin.analysis.resolve import AUTO, resolve_process, resolve_robot
from twin.analysis.tool_choice import resolve_tool_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.identify_sheet import forces_task, springback_task
from twin.errors import InputError
from twin.process.description import Process
from twin.process.process_file import ProcessDeclaration
from twin.runs.contact import require_forming_contact
from twin.runs.format import run_placement, run_process
from twin.runs.read import read_run
from twin.sim.spec import TwinSpec

METHODS = (1, 2)


@dataclass(frozen=True)
class IdentifyRequest:
    """What to identify: K_R and K_q by `method` (the default), else the sheet's forces or its springback.

    Attributes:
        method: 1: K_R from static load cases (`loads`); 2: from a nominal run (`run_dir`).
        loads: Method 1's load cases CSV (fx_n, fy_n, fz_n, dx_mm, dy_mm, dz_mm, one row per case), or None.
        run_dir: Method 2's run folder (tx200-twin-run/1 with forces.csv), or None.
        forces: A run whose measured forces the sheet force model's level and shape are fitted to, or None.
        springback: A run whose part scan the springback is fitted to (with `design`), or None.
        design: With `springback`: the part's design surface (STL).
        model: With `forces` or `springback`: the twin model file to start from, or None.
        declaration: With `forces` or `springback`: the process declared over the model's and the run's.
        force_model: With `forces` or `springback`: a registered force model, or "auto".
        robot: A robot name or description file (a run's own must match), or None.
        write_model: Where to put the result into the twin (a model file; K_q also as `*.xml` MJCF), or None.
        cell: A `--cell` file's record: its tool is the twin's (below a run's, `resolve_tool_spec`), or None.
    """

    method: int = 1
    loads: Path | None = None
    run_dir: Path | None = None
    forces: Path | None = None
    springback: Path | None = None
    design: Path | None = None
    model: Path | None = None
    declaration: ProcessDeclaration = field(default_factory=ProcessDeclaration)
    force_model: str = AUTO
    robot: str | Path | None = None
    write_model: Path | None = None
    cell: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise InputError(f"method {self.method!r}: expected one of {', '.join(map(str, METHODS))}")
        problem = _conflict(self)
        if problem is not None:
            raise InputError(problem)


def _conflict(request: IdentifyRequest) -> str | None:
    """What is wrong with the request's combination of inputs, in the order the command checks it; None: nothing."""
    if request.springback is not None:
        if request.run_dir is not None or request.loads is not None or request.forces is not None:
            return ("--springback RUN takes no other run directory, no --loads and no --forces (run --forces first "
                    "and pass its --write-model file as --model)")
        if request.design is None:
            return "--springback RUN needs --design DESIGN (the part's design surface, e.g. path --design-stl)"
        return None
    if request.design is not None:
        return "--design DESIGN goes with --springback RUN"
    if request.forces is not None:
        return ("--forces RUN takes no other run directory and no --loads"
                if request.run_dir is not None or request.loads is not None else None)
    if request.method == 2:
        return "--method 2 needs a RUN_DIR (a nominal run with forces.csv)" if request.run_dir is None else None
    if request.loads is None:
        return "--method 1 needs --loads FILE.csv (columns fx_n, fy_n, fz_n, dx_mm, dy_mm, dz_mm)"
    if request.run_dir is not None:
        return f"--method 1 takes no run directory (got {request.run_dir}); use --loads FILE.csv"
    return None


def _matrix_lines(matrix: np.ndarray, decimals: int = 2) -> list[str]:
    """A matrix as indented rows of fixed-width numbers."""
    return ["    [" + ", ".join(f"{value:10.{decimals}f}" for value in row) + "]" for row in matrix]


def _axes_label(names: list[str]) -> str:
    """'rows Fx, Fz; columns dUx, dUz' for the axes `names`."""
    return f"rows {', '.join('F' + n for n in names)}; columns {', '.join('dU' + n for n in names)}"


@dataclass(frozen=True)
class Method1Report(Report):
    """K_R from static load cases (thesis Method 1) and the diagonal K_q it implies at home (Eqs. 4.4-4.5).

    Attributes:
        loads: The load cases file.
        cases: How many load cases it holds.
        fit: The K_R fit [N/m].
        joint: The K_q fit (NaN for unobservable joints).
        k_q_nm_per_rad: K_q with the unobservable joints at the model's value [N·m/rad], shape (dof,).
        model_written: The model file written, or None.
    """

    loads: Path
    cases: int
    fit: KrFit
    joint: KqFit
    k_q_nm_per_rad: np.ndarray
    model_written: Path | None = None

    @property
    def c_r_xz_mm_per_kn(self) -> np.ndarray:
        """C_R x-z with y held (thesis Eq. 4.27a): the inverse of K_R's x-z sub-block [mm/kN], shape (2, 2)."""
        return 1e3 * np.linalg.inv(self.fit.k_r_n_per_mm[np.ix_([0, 2], [0, 2])])

    @property
    def c_r_mm_per_kn(self) -> np.ndarray:
        """C_R = inv(K_R), every axis (y free) [mm/kN], shape (3, 3)."""
        return 1e3 * np.linalg.inv(self.fit.k_r_n_per_mm)

    def lines(self) -> list[str]:
        fit = self.fit
        return [
            f"Method 1: {self.cases} load case(s) from {self.loads}",
            "K_R [N/mm] (rows Fx, Fy, Fz; columns dUx, dUy, dUz):",
            *_matrix_lines(fit.k_r_n_per_mm),
            "C_R = inv(K_R) [mm/kN] (rows dUx, dUy, dUz; columns Fx, Fy, Fz):",
            *_matrix_lines(self.c_r_mm_per_kn, 4),
            "C_R x-z, y held (thesis Eq. 4.27a) [mm/kN]:",
            *_matrix_lines(self.c_r_xz_mm_per_kn),
            f"residuals [N]: {', '.join(f'{r:.2f}' for r in fit.residuals_n)}",
            f"condition number of the deflections: {fit.condition_number:.3g}; rank {fit.rank}",
            "K_q [N·m/rad] (unobservable joints keep the model's): "
            + ", ".join(f"{k:.3g}{'' if ok else '*'}"
                        for k, ok in zip(self.k_q_nm_per_rad, self.joint.observable, strict=True)),
        ]

    def record(self) -> dict[str, Any]:
        payload: dict[str, Any] = {
            "method": 1, "loads": str(self.loads), "k_r_n_per_mm": self.fit.k_r_n_per_mm,
            "c_r_mm_per_kn": self.c_r_mm_per_kn, "c_r_xz_y_held_mm_per_kn": self.c_r_xz_mm_per_kn,
            "axes": ["x", "y", "z"], "rows": ["fx", "fy", "fz"],
            "columns": ["dux", "duy", "duz"], "residuals_n": self.fit.residuals_n,
            "condition_number": self.fit.condition_number, "rank": self.fit.rank,
            "joint_stiffness_nm_per_rad": self.k_q_nm_per_rad, "joint_observable": self.joint.observable,
            "joint_stiffness_route": "diagonal K_q with J K_q^-1 J^T ~ K_R^-1 at home (Eqs. 4.4-4.5); "
            "unobservable joints keep the model's value",
            "joint_fit_relative_residual": self.joint.relative_residual,
        }
        if self.model_written is not None:
            payload["model_written"] = self.model_written
        return payload


@dataclass(frozen=True)
class Method2Report(Report):
    """K_R from a nominal run (thesis Method 2), against the twin's compliance, and K_q fitted by rollouts.

    Attributes:
        run_dir: The run.
        result: Method 2's fits (ideal and measured forces) [N/m, m/N], over the axes the run supports.
        c_twin_m_per_n: The twin's compliance at home in the run's sheet frame, every axis [m/N], shape (3, 3).
        rollout: K_q fitted to the run by twin replays.
        joints: The robot's joint names.
        model_written: The model file written, or None.
    """

    run_dir: Path
    result: Method2Result
    c_twin_m_per_n: np.ndarray
    rollout: KqRolloutFit
    joints: tuple[str, ...]
    model_written: Path | None = None

    @property
    def c_twin_fitted_m_per_n(self) -> np.ndarray:
        """The twin's compliance over the fitted axes [m/N], shape (k, k)."""
        return self.c_twin_m_per_n[np.ix_(self.result.axes, self.result.axes)]

    def _off_twin(self, c_m_per_n: np.ndarray) -> float:
        """How far a compliance (over the fitted axes) is off the twin's, relative [-]."""
        twin = self.c_twin_fitted_m_per_n
        return float(np.linalg.norm(c_m_per_n - twin) / np.linalg.norm(twin))

    def lines(self) -> list[str]:
        r = self.result
        names = r.axis_names
        block = "-".join(names)
        why = ("" if len(names) == 3 else f" (the run's forces do not span y: smallest/largest singular value "
               f"{r.force_span:.3f} < {MIN_FORCE_SPAN:g}; no y row or column is fitted)")
        return [
            f"identify method 2 on {self.run_dir} ({r.samples} samples): the {block} block{why}",
            f"K_R (ideal forces, thesis) [N/mm] ({_axes_label(names)}):",
            *_matrix_lines(1e-3 * r.k_r_ideal_n_per_m),
            "K_R (measured forces) [N/mm]:",
            *_matrix_lines(1e-3 * r.k_r_measured_n_per_m),
            f"compliance from measured forces off the twin's {block} block by "
            f"{100 * self._off_twin(r.c_measured_m_per_n):.2f} %, from ideal forces by "
            f"{100 * self._off_twin(r.c_ideal_m_per_n):.2f} %; sheet force fell by {100 * r.force_drop:.1f} % rms",
        ]

    def record(self) -> dict[str, Any]:
        r, rollout = self.result, self.rollout
        fitted = ", ".join(name for name, ok in zip(self.joints, rollout.fitted, strict=True) if ok)
        payload: dict[str, Any] = {
            "method": 2, "run": self.run_dir, "samples": r.samples, "axes": r.axis_names,
            "force_span": r.force_span,
            "k_r_n_per_mm": 1e-3 * r.k_r_ideal_n_per_m,
            "c_r_mm_per_kn": 1e6 * np.linalg.inv(r.k_r_ideal_n_per_m),  # thesis Eq. 4.27b: inv(K_R(2))
            "k_r_measured_forces_n_per_mm": 1e-3 * r.k_r_measured_n_per_m,
            "compliance_ideal_forces_mm_per_kn": 1e6 * r.c_ideal_m_per_n,
            "compliance_measured_forces_mm_per_kn": 1e6 * r.c_measured_m_per_n,
            "twin_compliance_xz_mm_per_kn": 1e6 * self.c_twin_m_per_n[np.ix_([0, 2], [0, 2])],
            "twin_compliance_mm_per_kn": 1e6 * self.c_twin_m_per_n,
            "twin_compliance_fitted_axes_mm_per_kn": 1e6 * self.c_twin_fitted_m_per_n,
            "relative_error_measured_vs_twin": self._off_twin(r.c_measured_m_per_n),
            "relative_bias_ideal_vs_twin": self._off_twin(r.c_ideal_m_per_n),
            "force_drop_rms_ratio": r.force_drop,
            "joint_stiffness_nm_per_rad": rollout.k_q_nm_per_rad, "joint_fitted": rollout.fitted,
            "joint_relative_std": rollout.relative_std,
            "joint_stiffness_route": f"rollouts: least squares over twin replays of the run ({fitted})",
            "joint_fit_residual_rms_mm": rollout.residual_rms_mm, "joint_fit_evaluations": rollout.evaluations,
        }
        if self.model_written is not None:
            payload["model_written"] = self.model_written
        return payload


def identify_task(request: IdentifyRequest, note: Note = silent) -> Report:
    """Identify what the request asks: the sheet's springback or forces if it names a run for them, else K_R and
    K_q by its method.

    Raises:
        InputError: A rank-deficient or badly scaled load file, another robot than the run's, a run without what
            the fit needs (forces.csv, part_scan.csv).
        RunFormatError: A bad run folder (naming the file and row).
    """
    if request.springback is not None:
        return springback_task(request, note)
    if request.forces is not None:
        return forces_task(request, note)
    return _method2(request, note) if request.method == 2 else _method1(request)


def _method1(request: IdentifyRequest) -> Method1Report:
    """Method 1 on the request's load cases, and K_q through the Jacobian at home."""
    assert request.loads is not None  # checked by the request
    f_n, d_m = load_cases_csv(request.loads)
    fit = fit_kr_load_cases(f_n, d_m)
    robot = resolve_robot(request.robot)
    # the Jacobian at home is the cell tool's: K_q from K_R depends on the tool's length
    twin = TwinSpec(robot=robot, tool=resolve_tool_spec(robot, cell=request.cell)).build()
    joint = kq_from_stiffness(twin, fit.k_r_n_per_m)
    k_q = np.where(np.isfinite(joint.k_q_nm_per_rad), joint.k_q_nm_per_rad, twin.joint_stiffness)
    written = None
    if request.write_model is not None:
        written = write_joint_stiffness(request.write_model, k_q, note=f"K_q from Method 1 on {request.loads}",
                                        spec=TwinSpec(robot=twin.robot, tool=twin.spec.tool))
    return Method1Report(request.loads, len(f_n), fit, joint, k_q, written)


def _method2(request: IdentifyRequest, note: Note = silent) -> Method2Report:
    """Method 2 on the request's run (its recorded process and force model), and K_q by rollouts; each stage said
    as it starts (the rollouts replay the run a few dozen times)."""
    assert request.run_dir is not None  # checked by the request
    measured = read_run(request.run_dir)
    note(f"identify: Method 2 on {request.run_dir} ({len(measured.tracker.t_s)} tracker samples): K_R from the "
         "measured and the ideal forces")
    require_forming_contact(measured, "Method 2")
    robot = resolve_robot(request.robot, None, measured)
    # the run's recorded process and force model, else the first that applies to its path (a cone is no groove)
    process = resolve_process(run_process(measured.meta, Process()), request.declaration, request.force_model,
                              measured.commanded.values, measured.meta, "the run's recorded process", note=note)
    result = method2(measured, process)
    spec = TwinSpec(robot=robot, process=process, placement=run_placement(measured.meta),
                    tool=resolve_tool_spec(robot, run=measured, cell=request.cell))
    twin = spec.build()
    R = twin.R_base_sheet  # the twin's compliance at home, in the run's sheet frame
    c_twin = R.T @ twin.kinematics.compliance(twin.kinematics.q_home) @ R
    note("identify: K_q by least squares over twin replays of the run (rollouts)")
    rollout = kq_from_run(measured, spec)
    written = None
    if request.write_model is not None:
        written = write_joint_stiffness(request.write_model, rollout.k_q_nm_per_rad,
                                        note=f"K_q by rollouts on {request.run_dir}", spec=spec)
    return Method2Report(request.run_dir, result, c_twin, rollout, tuple(twin.robot.joints), written)
