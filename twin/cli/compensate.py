"""`tx200-twin compensate`: offline compensation of the groove path (formula Eq. 4.28, or with the twin)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

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
from twin.base.csvio import write_table
from twin.base.jsonio import emit_json, read_json
from twin.cli._common import (
    add_force_model_argument,
    add_history_arguments,
    add_ideal_argument,
    add_json_argument,
    add_placement_arguments,
    add_process_arguments,
    add_robot_argument,
    history_from_arguments,
    ideal_from_arguments,
    spec_from_arguments,
)
from twin.cli._types import count, finite
from twin.errors import DataFileError, InputError
from twin.process.fe.load import ForceHistory
from twin.process.force.registry import build_force_field
from twin.process.process_file import process_record
from twin.process.toolpath.groove import ToolPath
from twin.sim.spec import TwinSpec

HELP = "Compensate the ideal path offline (Eq. 4.28 formula, or iterating the twin) and write the command."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `compensate` options."""
    parser.add_argument("--method", required=True, choices=("formula", "twin"))
    parser.add_argument(
        "--stiffness", type=Path, help="JSON with k_r_n_per_mm (2x2 x-z or 3x3); formula only"
    )
    parser.add_argument("--model", type=Path, help="twin model file (effects, K_q, process) for --method twin")
    add_history_arguments(parser)
    add_ideal_argument(parser)
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    add_placement_arguments(parser, "sheet placement (the twin's)")
    parser.add_argument(
        "--tol-mm", type=finite, default=1e3 * TWIN_TOL_M, help="--method twin: stop when the rms residual is within this [mm]"
    )
    parser.add_argument("--max-iter", type=count, default=TWIN_MAX_ITER, help="--method twin: iteration limit")
    part = parser.add_argument_group("the formed part to the design (--method twin, a height-map force model)")
    part.add_argument("--target-stl", type=Path, metavar="DESIGN",
                      help="design surface (STL, PLY or OBJ; sheet frame, mm, tool side, z = 0 at the sheet's top): "
                      "compensate so that the twin's part after unclamping lies on it, springback included")
    part.add_argument("--part-iterations", type=count, default=2, help="outer iterations on the part (default 2)")
    part.add_argument("--learn-from", type=Path, metavar="RUN",
                      help="the last part's run (its command, part scan and tool radius): the next command learned "
                      "from its scan (--learn-at)")
    part.add_argument("--learn-at", choices=("twin", "formed", "tip"), default="twin",
                      help="how the scan's error is learned: twin, as the part's miss of the twin's prediction, "
                      "with the next command the twin's part compensation to the design minus that miss (needs "
                      "--ideal); formed, the command moved by the error of the surface each sample formed (the "
                      "tool resting on the design); tip, by the error under its own tip's x-y (default twin)")
    part.add_argument("--learn-gain", type=finite, default=1.0, help="learning gain (0, 1] (default 1)")
    part.add_argument("--learn-smoothing-mm", type=finite, default=2.0,
                      help="Gaussian smoothing of the learned error, along the path (tip, formed) or over x-y "
                      "(twin), > 0 (default 2)")
    part.add_argument("--figure", type=Path, metavar="PNG",
                      help="deviation maps from the design: the twin's predicted part at each iteration "
                      "(with --learn-from: the last part's scan)")
    part.add_argument("--rrd", type=Path, metavar="RRD",
                      help="rerun recording: the design, and each iteration's surface coloured by its deviation")
    parser.add_argument("--out", type=Path, required=True, help="compensated path, commanded.csv format")
    add_json_argument(parser, "the numbers")


SYMMETRY_TOLERANCE = 0.25  # |K - K^T| / max|K| allowed: Method 2 on a noisy lab run fits up to ~0.15


def _stiffness(path: Path) -> np.ndarray:
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


def _part(args: argparse.Namespace) -> int:
    """`--target-stl`: the part to the design, on the twin, or learned from the last part's scan."""
    from twin.analysis.part_compensation import PartStage, compensate_part, predicted_surface
    from twin.analysis.scan_learning import learn_from_scan, twin_discrepancy
    from twin.analysis.surface_check import read_target_mesh, region_deviation
    from twin.process.description import Process
    from twin.runs.format import run_process
    from twin.runs.read import read_run

    if args.method != "twin":
        raise InputError("--target-stl needs --method twin (the twin predicts the part after unclamping)")
    if args.learn_from is not None and not (0.0 < args.learn_gain <= 1.0 and args.learn_smoothing_mm > 0.0):
        raise InputError(f"--learn-gain {args.learn_gain:g} must be in (0, 1] and --learn-smoothing-mm "
                         f"{args.learn_smoothing_mm:g} > 0")
    if args.learn_from is not None and args.learn_at == "twin" and args.ideal is None:
        raise InputError("--learn-at twin needs --ideal PART.csv (the part's tool path: the twin's part "
                         "compensation keeps its x-y), or --learn-at formed|tip (the last command moved)")
    design = read_target_mesh(args.target_stl)
    protect = [p for p in (args.target_stl, args.ideal, args.learn_from, args.model) if p is not None]
    if args.learn_from is not None:
        last = read_run(args.learn_from)
        if last.part_scan is None:
            raise InputError(f"--learn-from {args.learn_from}: the run has no part_scan.csv to learn from")
        scan = last.part_scan
        scanned = PartStage(f"scan of {Path(args.learn_from).name}", "scanned", region_deviation(scan, design))
    if args.learn_from is not None and args.learn_at == "twin":
        ideal = ideal_from_arguments(args)
        twin = spec_from_arguments(args, ideal.p_sheet_m).build()
        field = twin_discrepancy(scan, predicted_surface(twin, last.commanded.t_s, last.commanded.values),
                                 1e-3 * args.learn_smoothing_mm)
        result = compensate_part(ideal, twin, design, iterations=args.part_iterations, tol_m=1e-3 * args.tol_mm,
                                 discrepancy=lambda xy: args.learn_gain * field(xy))
        command, t_s = result.compensation.p_cmd_sheet_m, ideal.t_s
        stages = [scanned, *result.stages()]
        miss = field(scan[:, :2])
        summary: dict[str, Any] = {
            "method": "learn", "out": args.out, "learned_from": args.learn_from, "gain": args.learn_gain,
            "smoothing_mm": args.learn_smoothing_mm, "at": "twin", "iterations": args.part_iterations,
            "twin_miss_rms_mm": 1e3 * float(np.sqrt(np.nanmean(miss**2))),
            "predicted_surface_rms_mm_per_iteration": [{region: stats["rms_mm"] for region, stats in e.items()}
                                                      for e in result.error_per_iteration],
        }
    elif args.learn_from is not None:
        stages = [scanned]
        radius = run_process(last.meta, Process(), Path(args.learn_from) / "meta.json").tool_radius_m
        learned = learn_from_scan(last.commanded.values, scan, design, gain=args.learn_gain,
                                  smoothing_m=1e-3 * args.learn_smoothing_mm, tool_radius_m=radius, at=args.learn_at)
        command, measured, t_s = learned.command_m, learned.measured_m, last.commanded.t_s
        seen = np.isfinite(measured)
        summary = {
            "method": "learn", "out": args.out, "learned_from": args.learn_from, "gain": args.learn_gain,
            "smoothing_mm": args.learn_smoothing_mm, "at": args.learn_at, "tool_radius_mm": 1e3 * radius,
            "samples_forming_scanned_points": int((learned.formed_points > 0).sum()),
            "samples_seen": int(seen.sum()), "samples": len(seen),
            "measured_error_rms_mm": 1e3 * float(np.sqrt(np.mean(measured[seen] ** 2))) if seen.any() else None,
        }
    else:
        ideal = ideal_from_arguments(args)
        twin = spec_from_arguments(args, ideal.p_sheet_m).build()
        result = compensate_part(ideal, twin, design, iterations=args.part_iterations, tol_m=1e-3 * args.tol_mm)
        command, t_s, stages = result.compensation.p_cmd_sheet_m, ideal.t_s, result.stages()
        summary = {
            "method": "part", "out": args.out, "iterations": args.part_iterations,
            "predicted_surface_rms_mm_per_iteration": [{region: stats["rms_mm"] for region, stats in e.items()}
                                                      for e in result.error_per_iteration],
        }
    write_table(
        args.out, {"t_s": t_s, **{f"{a}_mm": 1e3 * command[:, i] for i, a in enumerate("xyz")}},
        formats={"t_s": ".6f", "x_mm": ".4f", "y_mm": ".4f", "z_mm": ".4f"}, protect=protect,
    )
    if args.figure is not None:
        from twin.viz.surface_figures import plot_part_stages

        title = f"{Path(args.target_stl).name}: " + ("the last part's scan" if args.learn_from else "the twin's part")
        summary["figure"] = str(plot_part_stages(args.figure, stages, title=title, protect=protect))
    if args.rrd is not None:
        from twin.viz.part_recording import record_part

        summary["rrd"] = str(record_part(args.rrd, design, stages, protect=protect))
    print(f"compensate ({summary['method']}): -> {args.out}", file=sys.stderr if args.json == "-" else sys.stdout)
    emit_json(args.json, summary, protect=protect)
    return 0


def run(args: argparse.Namespace) -> int:
    """Compensate."""
    from twin.analysis.check import diagnose_gain  # the check loads the twin

    if args.target_stl is not None:
        return _part(args)
    for option, value in (("--learn-from", args.learn_from), ("--figure", args.figure), ("--rrd", args.rrd)):
        if value is not None:
            raise InputError(f"{option} needs --target-stl DESIGN (the surface the part is measured against); "
                             f"got {option} {value} without it")
    declared, reference = history_from_arguments(args)
    ideal = ideal_from_arguments(args)
    protect = [p for p in (args.stiffness, args.model, args.history, args.ideal, args.process) if p is not None]
    spec = spec_from_arguments(args, ideal.p_sheet_m, history=declared)
    f_reference = build_force_field(spec.process, reference).rigid_forces(ideal)
    comp, c_r, predicted, f_used = _compensate(args, spec, ideal, declared)
    gain = gain_of(comp, f_reference, c_r)
    record = CompensationRecord(args.method, comp.t_s, f_used, declared.symmetry, declared.column_symmetry,
                                None if args.history is None else str(args.history))
    write_table(
        args.out,
        {"t_s": comp.t_s, **{f"{a}_mm": 1e3 * comp.p_cmd_sheet_m[:, i] for i, a in enumerate("xyz")}},
        formats={"t_s": ".6f", "x_mm": ".4f", "y_mm": ".4f", "z_mm": ".4f"},
        protect=protect,
    )
    record_file = write_record(args.out, record)
    norm = np.linalg.norm(predicted, axis=1)
    summary = {
        "method": args.method,
        "out": args.out,
        "gain": gain,
        "gain_diagnosis": diagnose_gain(gain, record, ideal.t_s, f_reference),
        "record": record_file,
        "iterations": comp.iterations,
        "converged": comp.converged,
        "residual_rms_per_iteration_mm": [1e3 * h for h in comp.history_m],
        "predicted_residual_rms_mm": 1e3 * float(np.sqrt(np.mean(norm**2))),
        "predicted_residual_max_mm": 1e3 * float(np.max(norm)),
        "correction_max_mm": 1e3 * float(np.max(np.linalg.norm(comp.correction_m, axis=1))),
        "compliance_mm_per_kn": 1e6 * c_r,
        "history": {"file": declared.source, "symmetry": declared.symmetry},
        "force_model": spec.process.force_model,
        "process": process_record(spec.process),
        "effects": dict(spec.effects.values),
    }
    _report(args, summary, comp.converged, summary["gain_diagnosis"])
    emit_json(args.json, summary, protect=protect)
    return 0


def _compensate(
    args: argparse.Namespace, spec: TwinSpec, ideal: ToolPath, declared: ForceHistory
) -> tuple[Compensation, np.ndarray, np.ndarray, np.ndarray]:
    """The compensation of `--method`, the compliance its gain is measured with [m/N], the twin's predicted
    residual of the command [m], shape (n, 3), and the forces it assumed at each sample [N], shape (n, 3)."""
    twin = spec.build()
    if args.method == "formula":
        if args.stiffness is None:
            raise InputError("--method formula needs --stiffness FILE with k_r_n_per_mm (e.g. an identify output)")
        c_r = compliance_from_stiffness(_stiffness(args.stiffness))
        f_ideal = build_force_field(spec.process, declared).rigid_forces(ideal)
        comp = compensate_formula(ideal.t_s, ideal.p_sheet_m, f_ideal, c_r)
        return comp, c_r, twin.simulate(comp.t_s, comp.p_cmd_sheet_m).p_sheet_m - ideal.p_sheet_m, f_ideal
    if not (args.tol_mm > 0 and args.max_iter >= 1):
        raise InputError(f"--tol-mm {args.tol_mm} and --max-iter {args.max_iter}: expected > 0 and >= 1")
    comp = compensate_twin(ideal.t_s, ideal.p_sheet_m, twin, tol_m=1e-3 * args.tol_mm, max_iter=args.max_iter)
    assert comp.predicted_residual_m is not None
    f_twin = twin.simulate(comp.t_s, comp.p_cmd_sheet_m).f_sheet_n  # the forces the twin predicts for its command
    return comp, twin.kinematics.compliance(twin.kinematics.q_home), comp.predicted_residual_m, f_twin


def _report(args: argparse.Namespace, summary: dict[str, Any], converged: bool, diagnosis: str) -> None:
    """The human summary (on stderr when the JSON goes to stdout)."""
    out = sys.stderr if args.json == "-" else sys.stdout  # keep stdout pure JSON for `--json -`
    gain = summary["gain"]
    print(
        f"compensate ({args.method}): gain {gain:.3f}, {summary['iterations']} iteration(s), predicted residual rms "
        f"{summary['predicted_residual_rms_mm']:.4f} mm, max correction {summary['correction_max_mm']:.2f} mm "
        f"-> {args.out}",
        file=out,
    )
    if not converged:
        print(
            f"note: the twin iteration stalled at {summary['predicted_residual_rms_mm']:.4f} mm rms (max "
            f"{summary['predicted_residual_max_mm']:.3f} mm, where joint friction flips: reversals, corners, "
            "stick-slip); the best command is written",
            file=out,
        )
    if abs(gain - 1.0) > 0.02:
        print(f"warning: {diagnosis}", file=out)
