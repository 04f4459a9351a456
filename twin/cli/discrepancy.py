"""`tx200-twin discrepancy`: find where twin and run disagree, name the missing effect, add it, show the shrink."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from twin.base.csvio import emit_json
from twin.cli._common import (
    add_force_model_argument,
    add_history_arguments,
    add_process_arguments,
    add_robot_argument,
    history_from_arguments,
    spec_from_arguments,
)
from twin.process.process_file import process_record
from twin.runs.read import read_run
from twin.sim.model_file import write_model_file

HELP = (
    "Find where the twin and a measured run disagree, name the missing effect, add it, show the gap shrink."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `discrepancy` options."""
    parser.add_argument("run_dir", type=Path, help="a tx200-twin-run/1 directory (truth.json is never read)")
    parser.add_argument("--model", type=Path, help="start from this twin model file (effects, K_q, process)")
    add_history_arguments(parser)
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    parser.add_argument("--model-out", type=Path, help="write the augmented twin model file here")
    parser.add_argument(
        "--report", type=Path, help="write figures of the residual before/after into this folder"
    )
    parser.add_argument("--json", help="write the findings to FILE ('-' for stdout)")


def run(args: argparse.Namespace) -> int:
    """Run the workflow."""
    from twin.analysis.discrepancy.search import find_discrepancy
    from twin.analysis.discrepancy.summary import result_summary

    measured = read_run(args.run_dir)
    declared, _ = history_from_arguments(args)
    spec = spec_from_arguments(args, measured.commanded.values, run=measured, history=declared)
    result = find_discrepancy(measured, spec)
    summary = {
        "run": args.run_dir,
        **result_summary(result),
        "process": {**process_record(spec.process), "force_model": spec.process.force_model},
    }
    protect = [p for p in (args.run_dir, args.model, args.history, args.process) if p is not None]
    if args.model_out is not None:
        write_model_file(
            args.model_out,
            spec.replace(effects=result.effects),
            note=(f"tx200-twin discrepancy on {args.run_dir}: found {list(result.found) or result.verdict}"
                  + ("" if result.model_complete else "; families without an effect of their own are not in this file")),
            protect=protect,
        )
        summary["model_out"] = args.model_out
    if args.report is not None:
        from twin.viz.deflection_figures import plot_residual_before_after

        args.report.mkdir(parents=True, exist_ok=True)
        figure = plot_residual_before_after(
            args.report / "residual_before_after.png",
            measured.tracker.t_s,
            result.residual_before["position"],
            result.residual_after["position"],
            label_before="twin as given",
            label_after=f"twin + {', '.join(result.found) or 'nothing'}",
        )
        summary["report"] = [figure]
    out = sys.stderr if args.json == "-" else sys.stdout
    before, after = result.gap_before, result.gap_after
    named = ", ".join(f"{n.reported_name} ({100 * n.explained_fraction:.0f} %)" for n in result.named)
    print(
        f"discrepancy {args.run_dir}: effect {summary['effect']} (found {named or 'nothing'}; "
        f"{100 * result.explained_fraction:.0f} % of the gap explained); model parameters "
        f"{result.effects.named_parameters()}; position gap {before['position_rms_mm']:.3f} -> "
        f"{after['position_rms_mm']:.3f} mm, force gap {before['force_rms_n']:.1f} -> {after['force_rms_n']:.1f} N "
        f"(noise {result.noise['position_mm']:.3f} mm, {result.noise['force_n']:.1f} N per axis); "
        f"left: {result.remainder['words']}",
        file=out,
    )
    emit_json(args.json, summary, protect=protect)
    return 0
