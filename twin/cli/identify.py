"""`tx200-twin identify`: fit the robot's Cartesian stiffness K_R (thesis §4.2)."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from twin.analysis.identify.cartesian import fit_kr_load_cases, load_cases_csv
from twin.base.jsonio import emit_json
from twin.cli._common import (
    add_force_model_argument,
    add_json_argument,
    add_process_arguments,
    add_robot_argument,
    command_robot,
)
from twin.errors import InputError

HELP = ("Identify K_R (Method 1: load cases; Method 2: a run), the joint stiffness K_q, the sheet's forces, or the "
        "part's springback.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the command's options."""
    parser.add_argument(
        "--method",
        type=int,
        choices=(1, 2),
        default=1,
        help="1: static load cases (--loads); 2: a nominal run directory (RUN_DIR)",
    )
    parser.add_argument(
        "--loads",
        type=Path,
        help="Method 1 load cases CSV: fx_n, fy_n, fz_n, dx_mm, dy_mm, dz_mm (one row per case)",
    )
    parser.add_argument("run_dir", nargs="?", type=Path, help="Method 2: run directory (tx200-twin-run/1)")
    parser.add_argument(
        "--forces",
        type=Path,
        metavar="RUN",
        help="fit the sheet force model's level and shape to this run's measured forces (the process its meta.json "
        "records, or --process/--material ...); --write-model puts the fit into a twin model file",
    )
    parser.add_argument(
        "--springback",
        type=Path,
        metavar="RUN",
        help="fit the springback (a factor on the elastic recovery F/k_unload and the depth ratio kept) to this run's "
        "part scan against --design, the twin replaying its command (isf model); --write-model puts the fit into a "
        "twin model file (with --model's forces, e.g. from --forces on the same run)",
    )
    parser.add_argument("--design", type=Path, metavar="DESIGN", help="--springback: the part's design surface (STL)")
    parser.add_argument("--model", type=Path, help="--forces, --springback: start from this twin model file")
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    add_json_argument(parser, "the result")
    parser.add_argument(
        "--write-model",
        type=Path,
        metavar="FILE",
        help="put the identified K_q into the twin: FILE.json (twin model file) or FILE.xml (MJCF)",
    )


def _matrix_lines(matrix: np.ndarray) -> list[str]:
    return ["    [" + ", ".join(f"{value:10.2f}" for value in row) + "]" for row in matrix]


def _method2(args: argparse.Namespace) -> int:
    """Method 2 on a run directory."""
    from twin.analysis.identify.method2 import method2
    from twin.process.description import Process
    from twin.runs.format import run_placement, run_process
    from twin.runs.read import read_run
    from twin.sim.spec import TwinSpec

    if args.run_dir is None:
        raise InputError("--method 2 needs a RUN_DIR (a nominal run with forces.csv)")
    measured = read_run(args.run_dir)
    robot = command_robot(args, run=measured)
    process = run_process(measured.meta, Process())
    recorded_model = measured.meta.get("force_model")
    if isinstance(recorded_model, str):
        process = replace(process, force_model=recorded_model)
    result = method2(measured, process)
    spec = TwinSpec(robot=robot, process=process, placement=run_placement(measured.meta))
    twin = spec.build()
    R = twin.R_base_sheet  # the twin's compliance at home, in the run's sheet frame
    c_twin = (R.T @ twin.kinematics.compliance(twin.kinematics.q_home) @ R)[np.ix_([0, 2], [0, 2])]
    error = float(np.linalg.norm(result.c_measured_m_per_n - c_twin) / np.linalg.norm(c_twin))
    bias = float(np.linalg.norm(result.c_ideal_m_per_n - c_twin) / np.linalg.norm(c_twin))
    payload = {
        "method": 2,
        "run": args.run_dir,
        "samples": result.samples,
        "k_r_n_per_mm": 1e-3 * result.k_r_ideal_n_per_m,
        "c_r_mm_per_kn": 1e6 * np.linalg.inv(result.k_r_ideal_n_per_m),  # thesis Eq. 4.27b: inv(K_R(2))
        "k_r_measured_forces_n_per_mm": 1e-3 * result.k_r_measured_n_per_m,
        "compliance_ideal_forces_mm_per_kn": 1e6 * result.c_ideal_m_per_n,
        "compliance_measured_forces_mm_per_kn": 1e6 * result.c_measured_m_per_n,
        "twin_compliance_xz_mm_per_kn": 1e6 * c_twin,
        "relative_error_measured_vs_twin": error,
        "relative_bias_ideal_vs_twin": bias,
        "force_drop_rms_ratio": result.force_drop,
    }
    from twin.analysis.identify.rollouts import kq_from_run, write_joint_stiffness

    rollout = kq_from_run(measured, spec)
    fitted = ", ".join(name for name, ok in zip(twin.robot.joints, rollout.fitted, strict=True) if ok)
    payload |= {
        "joint_stiffness_nm_per_rad": rollout.k_q_nm_per_rad,
        "joint_fitted": rollout.fitted,
        "joint_relative_std": rollout.relative_std,
        "joint_stiffness_route": f"rollouts: least squares over twin replays of the run ({fitted})",
        "joint_fit_residual_rms_mm": rollout.residual_rms_mm,
        "joint_fit_evaluations": rollout.evaluations,
    }
    if args.write_model is not None:
        payload["model_written"] = write_joint_stiffness(
            args.write_model, rollout.k_q_nm_per_rad, note=f"K_q by rollouts on {args.run_dir}", spec=spec
        )
    print(
        f"identify method 2 on {args.run_dir} ({result.samples} samples): "
        f"K_R (ideal forces, thesis) [N/mm] = {np.round(payload['k_r_n_per_mm'], 1).tolist()}; "
        f"K_R (measured forces) = {np.round(payload['k_r_measured_forces_n_per_mm'], 1).tolist()}; "
        f"compliance from measured forces off the twin's x-z block by {100 * error:.2f} %, "
        f"from ideal forces by {100 * bias:.2f} %; sheet force fell by {100 * result.force_drop:.1f} % rms",
        file=sys.stderr if args.json == "-" else sys.stdout,  # keep stdout pure JSON for `--json -`
    )
    emit_json(args.json, payload, protect=[args.run_dir])
    return 0


def _forces(args: argparse.Namespace) -> int:
    """`--forces RUN`: the force model fitted to a run's measured forces."""
    from twin.analysis.identify.forces import FITTED, WINDOW_S, fit_forces
    from twin.cli._common import spec_from_arguments
    from twin.runs.read import read_run
    from twin.sim.model_file import write_model_file

    if args.run_dir is not None or args.loads is not None:
        raise InputError("--forces RUN takes no other run directory and no --loads")
    measured = read_run(args.forces)
    spec = spec_from_arguments(args, measured.commanded.values, run=measured)
    fit = fit_forces(measured, spec.process)
    payload: dict[str, object] = {
        "run": args.forces,
        "force_model": spec.process.force_model,
        "process": {"material": spec.process.material, "tensile_strength_mpa": spec.process.tensile_strength_mpa},
        "force_fit": dict(fit.force_fit),
        "force_rms_before_n": fit.rms_before_n,
        "force_rms_after_n": fit.rms_after_n,
        "samples": fit.samples,
        "window_s": WINDOW_S,
        "windows": fit.windows,
        "evaluations": fit.evaluations,
        "at_bound": list(fit.at_bound),
    }
    if args.write_model is not None:
        fitted = spec.replace(process=replace(spec.process, force_fit=fit.force_fit))
        payload["model_written"] = write_model_file(
            args.write_model, fitted, note=f"sheet forces fitted to {args.forces}", protect=[args.forces]
        )
    values = ", ".join(f"{k} {v:.4g}" for k, v in fit.force_fit)
    print(
        f"identify --forces {args.forces} ({spec.process.force_model} model, {fit.samples} samples): {values}; force "
        f"rms {fit.rms_before_n:.1f} N -> {fit.rms_after_n:.1f} N ({fit.windows} windows of {WINDOW_S:g} s)",
        file=sys.stderr if args.json == "-" else sys.stdout,
    )
    bounds = {name: (low, high) for name, low, high in FITTED[spec.process.force_model]}
    for name in fit.at_bound:
        print(f"warning: {name} ended on its bound {bounds[name]} (its value is the bound's, not the cell's): the "
              f"{spec.process.force_model} model cannot take this run's force history; force rms left "
              f"{fit.rms_after_n:.1f} N", file=sys.stderr)
    emit_json(args.json, payload, protect=[args.forces])
    return 0


def _springback(args: argparse.Namespace) -> int:
    """`--springback RUN --design DESIGN`: the springback constants fitted to a run's part scan."""
    from twin.analysis.identify.springback import fit_springback
    from twin.analysis.surface_check import read_target_mesh
    from twin.cli._common import spec_from_arguments
    from twin.runs.read import read_run
    from twin.sim.model_file import write_model_file

    if args.run_dir is not None or args.loads is not None or args.forces is not None:
        raise InputError("--springback RUN takes no other run directory, no --loads and no --forces (run --forces "
                         "first and pass its --write-model file as --model)")
    if args.design is None:
        raise InputError("--springback RUN needs --design DESIGN (the part's design surface, e.g. path --design-stl)")
    measured = read_run(args.springback, require_forces=False)
    if measured.part_scan is None:
        raise InputError(f"--springback {args.springback}: the run has no part_scan.csv (a scan of the formed part "
                         "is what shows its springback)")
    spec = spec_from_arguments(args, measured.commanded.values, run=measured)
    fit = fit_springback(measured, spec, read_target_mesh(args.design))
    payload: dict[str, object] = {
        "run": args.springback, "design": args.design, "force_model": spec.process.force_model,
        "force_fit_used": dict(spec.process.force_fit), "springback_fit": dict(fit.springback_fit),
        "scan_rms_before_mm": 1e3 * fit.rms_before_m, "scan_rms_after_mm": 1e3 * fit.rms_after_m,
        "points": fit.points, "evaluations": fit.evaluations, **fit.registration.summary_mm(),
    }
    if args.write_model is not None:
        process = replace(spec.process, force_fit=tuple((dict(spec.process.force_fit) | dict(fit.springback_fit))
                                                        .items()))
        payload["model_written"] = write_model_file(
            args.write_model, spec.replace(process=process), note=f"springback fitted to the scan of {args.springback}",
            protect=[args.springback, args.design],
        )
    values = ", ".join(f"{k} {v:.4g}" for k, v in fit.springback_fit)
    print(
        f"identify --springback {args.springback} ({fit.points} scan points): {values}; scan against the twin's part "
        f"{1e3 * fit.rms_before_m:.3f} mm -> {1e3 * fit.rms_after_m:.3f} mm rms",
        file=sys.stderr if args.json == "-" else sys.stdout,
    )
    emit_json(args.json, payload, protect=[args.springback, args.design])
    return 0


def run(args: argparse.Namespace) -> int:
    """Run the identification and report it."""
    if getattr(args, "springback", None) is not None:
        return _springback(args)
    if getattr(args, "design", None) is not None:
        raise InputError("--design DESIGN goes with --springback RUN")
    if getattr(args, "forces", None) is not None:
        return _forces(args)
    if args.method == 2:
        return _method2(args)
    if args.loads is None:
        raise InputError("--method 1 needs --loads FILE.csv (columns fx_n, fy_n, fz_n, dx_mm, dy_mm, dz_mm)")
    if args.run_dir is not None:
        raise InputError(f"--method 1 takes no run directory (got {args.run_dir}); use --loads FILE.csv")
    f_n, d_m = load_cases_csv(args.loads)
    fit = fit_kr_load_cases(f_n, d_m)
    # thesis Eq. 4.27a: C_R(1) is the inverse of K_R's x-z sub-block (y held) [mm/kN]
    c_r_xz = 1e3 * np.linalg.inv(fit.k_r_n_per_mm[np.ix_([0, 2], [0, 2])])
    payload = {
        "method": 1,
        "loads": str(args.loads),
        "k_r_n_per_mm": fit.k_r_n_per_mm,
        "c_r_xz_y_held_mm_per_kn": c_r_xz,
        "rows": ["fx", "fy", "fz"],
        "columns": ["dux", "duy", "duz"],
        "residuals_n": fit.residuals_n,
        "condition_number": fit.condition_number,
        "rank": fit.rank,
    }
    from twin.analysis.identify.rollouts import kq_from_stiffness, write_joint_stiffness
    from twin.sim.spec import TwinSpec

    twin = TwinSpec(robot=command_robot(args)).build()
    kq = kq_from_stiffness(twin, fit.k_r_n_per_m)
    k_q = np.where(np.isfinite(kq.k_q_nm_per_rad), kq.k_q_nm_per_rad, twin.joint_stiffness)
    payload |= {
        "joint_stiffness_nm_per_rad": k_q,
        "joint_observable": kq.observable,
        "joint_stiffness_route": "diagonal K_q with J K_q^-1 J^T ~ K_R^-1 at home (Eqs. 4.4-4.5); "
        "unobservable joints keep the model's value",
        "joint_fit_relative_residual": kq.relative_residual,
    }
    if args.write_model is not None:
        payload["model_written"] = write_joint_stiffness(
            args.write_model, k_q, note=f"K_q from Method 1 on {args.loads}", spec=TwinSpec(robot=twin.robot)
        )
    emit_json(args.json, payload, protect=[args.loads])
    out = sys.stderr if args.json == "-" else sys.stdout
    lines = [
        f"Method 1: {len(f_n)} load case(s) from {args.loads}",
        "K_R [N/mm] (rows Fx, Fy, Fz; columns dUx, dUy, dUz):",
        *_matrix_lines(fit.k_r_n_per_mm),
        "C_R x-z, y held (thesis Eq. 4.27a) [mm/kN]:",
        *_matrix_lines(c_r_xz),
        f"residuals [N]: {', '.join(f'{r:.2f}' for r in fit.residuals_n)}",
        f"condition number of the deflections: {fit.condition_number:.3g}; rank {fit.rank}",
        "K_q [N·m/rad] (unobservable joints keep the model's): "
        + ", ".join(f"{k:.3g}{'' if ok else '*'}" for k, ok in zip(k_q, kq.observable, strict=True)),
    ]
    print("\n".join(lines), file=out)
    return 0
