"""`tx200-twin learn`: from a cell's nominal runs, a twin of that cell (robot and sheet), saved as a model file."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.jsonio import emit_json
from twin.cli._common import add_json_argument
from twin.runs.read import read_run

HELP = ("Learn the cell's robot (joint compliance, friction, servo transient) and sheet (forces, springback) from "
        "its nominal runs.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `learn` options."""
    parser.add_argument("runs", type=Path, nargs="+", metavar="RUN",
                        help="nominal runs of one cell (tracker and F/T streams), one robot at one placement; "
                        "with two or more, each is also replayed on a twin learned from the others")
    parser.add_argument("--model", type=Path, help="the declared twin (model file) whose robot and process are the "
                        "priors (default: the runs' recorded robot and process)")
    parser.add_argument("--write-model", type=Path, help="write the learned twin to FILE (a model file that "
                        "`replay`, `compensate`, `discrepancy` and `place` take with --model)")
    add_json_argument(parser, "what was learned and the gaps")


def run(args: argparse.Namespace) -> int:
    """Learn from the runs."""
    from twin.analysis.learn import learn
    from twin.sim.model_file import read_model_file, write_model_file

    runs = [read_run(path) for path in args.runs]
    prior = read_model_file(args.model) if args.model is not None else None
    result = learn(runs, prior)
    out = sys.stderr if args.json == "-" else sys.stdout
    for line in summary_lines(result):
        print(line, file=out)
    protect = [*args.runs, *([args.model] if args.model is not None else [])]
    if args.write_model is not None:
        names = ", ".join(str(p) for p in args.runs)
        write_model_file(args.write_model, result.spec, protect=protect,
                         note=f"learned by `tx200-twin learn` from {names}: K_q, joint friction and the sheet's "
                         "force model are fitted to those runs")
        print(f"-> {args.write_model}", file=out)
    emit_json(args.json, payload(result), protect=protect)
    return 0


def summary_lines(result: Any) -> list[str]:
    """What was learned, for the screen."""
    robot, sheet = result.robot, result.sheet
    joints = []
    for j, (k, s, k0, seen) in enumerate(zip(robot.k_q_nm_per_rad, robot.std_nm_per_rad, robot.prior_nm_per_rad,
                                              robot.observable, strict=True)):
        if not seen:
            joints.append(f"j{j + 1} {k0 / 1e3:.0f} (prior: not observed)")
        elif s > 0.5 * k:  # its compliance is not told from 0: a lower bound
            joints.append(f"j{j + 1} > {k / (1 + 2 * s / k) / 1e3:.0f} (stiffer than the run resolves)")
        else:
            joints.append(f"j{j + 1} {k / 1e3:.0f} ± {s / 1e3:.0f} ({100 * (k0 / k - 1):+.0f} % compliance)")
    friction = ", ".join(f"j{j + 1} {f:.0f}" for j, f in enumerate(robot.friction_nm) if f > 0) or "none"
    fit = dict(sheet.force_fit)
    std = dict(sheet.std)
    lines = [
        f"learned from {len(result.before)} run(s) (fitted: the robot, the sheet and its springback come from these "
        "runs)",
        f"  robot: K_q [kN·m/rad] {'; '.join(joints)}",
        f"  robot: joint friction [N·m] {friction}; {_servo_words(robot)}; tracker offset ({', '.join(f'{v:.3f}' for v in robot.offset_mm)}) mm (not a robot "
        "effect: a registration error of the tracker)",
        "  robot's part of the gap (the twin's robot driven by the measured forces): "
        + ", ".join(f"{a:.3f} -> {b:.3f} mm" for a, b in zip(robot.rms_prior_mm, robot.rms_after_mm, strict=True)),
        f"  sheet ('learned' force model): prior weight {fit['prior_weight']:.3f} ± {std['prior_weight']:.3f}, side "
        f"membrane {fit['side_membrane_n']:.0f} ± {std['side_membrane_n']:.0f} N, side cubic "
        f"{fit['side_cubic_n']:.0f} ± {std['side_cubic_n']:.0f} N, ahead {fit['ahead_membrane_n']:.0f} ± "
        f"{std['ahead_membrane_n']:.0f} N, mu_t {fit['mu_eff']:.3f}, mu_r {fit['mu_radial']:.3f}",
        "  sheet's force along the measured tip: "
        + ", ".join(f"{a:.0f} -> {b:.0f} N" for a, b in zip(sheet.rms_before_n, sheet.rms_after_n, strict=True)),
    ]
    spring = result.springback
    if spring is not None:
        bound = f" (at its bound: {', '.join(spring.at_bound)})" if spring.at_bound else ""
        lines.append(f"  springback (from the part profiles): recovery {spring.recovery_scale:.3f} x the model's "
                     f"F/k_unload, depth kept {spring.depth_ratio:.3f}{bound}; profile "
                     + ", ".join(f"{a:.3f} -> {b:.3f} mm" for a, b in zip(spring.rms_before_mm, spring.rms_after_mm,
                                                                           strict=True)))
    else:
        lines.append("  springback: no part profile in the runs (a 3-D scan: `identify --springback RUN --design "
                     "STL`)")
    for before, after in zip(result.before, result.after, strict=True):
        lines.append(f"  replay {before.run}: {_gap(before)} -> {_gap(after)} (fitted)")
    for held in result.held_out:
        lines.append(f"  left out {held.run}: {_gap(held)} (predicted: learned from the other runs)")
    return lines


def _gap(gap: Any) -> str:
    profile = "" if np.isnan(gap.profile_rms_mm) else f", profile {gap.profile_rms_mm:.3f} mm"
    return f"{gap.position_rms_mm:.3f} mm / {gap.force_rms_n:.0f} N{profile}"


def _servo_words(robot: Any) -> str:
    if robot.servo is None:
        return "no servo transient seen"
    share = ", ".join(f"j{j + 1} {cs * k:.2f}" for j, (cs, k) in enumerate(
        zip(robot.servo.compliance_rad_per_nm, robot.k_q_nm_per_rad, strict=True)) if cs != 0)
    return (f"servo transient over {1e3 * robot.servo.time_constant_s:.0f} ms, its compliance over the joint's "
            f"{share} (negative: the deflection lags the force)")


def payload(result: Any) -> dict[str, Any]:
    """The `--json` document."""
    robot, sheet = result.robot, result.sheet

    def gaps(items: Any) -> list[dict[str, Any]]:
        return [g._asdict() for g in items]

    return {
        "robot": {
            "k_q_nm_per_rad": robot.k_q_nm_per_rad, "k_q_std_nm_per_rad": robot.std_nm_per_rad,
            "prior_k_q_nm_per_rad": robot.prior_nm_per_rad, "observable": np.asarray(robot.observable).tolist(),
            "friction_nm": robot.friction_nm, "tracker_offset_mm": robot.offset_mm,
            "servo": None if robot.servo is None else {
                "compliance_rad_per_nm": list(robot.servo.compliance_rad_per_nm),
                "time_constant_s": robot.servo.time_constant_s},
            "gap_measured_forces_prior_mm": list(robot.rms_prior_mm),
            "gap_measured_forces_learned_mm": list(robot.rms_after_mm),
        },
        "sheet": {"force_model": "learned", "force_fit": dict(sheet.force_fit), "std": dict(sheet.std),
                  "force_rms_before_n": list(sheet.rms_before_n), "force_rms_after_n": list(sheet.rms_after_n),
                  "samples": sheet.samples},
        "springback": None if result.springback is None else result.springback._asdict(),
        "before": gaps(result.before), "after_fitted": gaps(result.after), "held_out_predicted": gaps(result.held_out),
    }
