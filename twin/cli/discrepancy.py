"""`tx200-twin discrepancy`: find where twin and run disagree, name the missing effect, add it, show the shrink."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from twin.base.jsonio import emit_json
from twin.cli._common import (
    add_force_model_argument,
    add_history_arguments,
    add_json_argument,
    add_process_arguments,
    add_robot_argument,
    history_from_arguments,
    spec_from_arguments,
)
from twin.errors import InputError
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
    parser.add_argument("--no-learn", action="store_true",
                        help="when no family explains the gap, do not learn the robot and the sheet from the run")
    parser.add_argument("--held-out", type=Path, metavar="RUN",
                        help="another run of the same cell, not learned from: the gap before -> after on it")
    add_json_argument(parser, "the findings")


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
    protect = [p for p in (args.run_dir, args.model, args.history, args.process, args.held_out) if p is not None]
    learned = None
    if result.verdict == "unexplained" and measured.forces is not None and not args.no_learn:
        try:
            learned = _learn(args, measured, spec.replace(effects=result.effects))
            summary["learned"] = learned
        except InputError as exc:  # the run cannot teach the twin (a silent sensor, ...): the search still stands
            summary["learned"] = {"refused": str(exc)}
            print(f"note: no family explains the gap, and the run cannot teach the twin: {exc}", file=sys.stderr)
    if args.model_out is not None and learned is not None:
        write_model_file(args.model_out, learned.pop("spec"), protect=protect,
                         note=f"tx200-twin discrepancy on {args.run_dir}: unexplained by the families; robot and "
                         "sheet learned from the run (fitted)")
        summary["model_out"] = args.model_out
    elif args.model_out is not None:
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
    if learned is not None:
        learned.pop("spec", None)
        print("  no family explains it; learned from the run (fitted):", file=out)
        for sentence in learned["named"]:
            print(f"  - {sentence}", file=out)
        for label, key in (("this run (fitted)", "run"), ("held-out run (predicted)", "held_out")):
            if key in learned:
                g = learned[key]
                print(f"  gap on {label}: {g['before_mm']:.3f} -> {g['after_mm']:.3f} mm, {g['before_n']:.0f} -> "
                      f"{g['after_n']:.0f} N", file=out)
    emit_json(args.json, summary, protect=protect)
    return 0


def _learn(args: argparse.Namespace, measured: Any, spec: Any) -> dict[str, Any]:
    """Learn the robot and the sheet from the run; the sentences naming them and the gaps before and after."""
    from twin.analysis.learn import learn
    from twin.analysis.learn.cell import replay_gap
    from twin.analysis.learn.signatures import robot_sentences, sheet_sentences, springback_sentences

    def gaps(before: Any, after: Any) -> dict[str, float]:
        return {"before_mm": before.position_rms_mm, "after_mm": after.position_rms_mm,
                "before_n": before.force_rms_n, "after_n": after.force_rms_n}

    result = learn([measured], spec)
    named = sheet_sentences(measured, spec) + springback_sentences(result) + robot_sentences(result)
    out: dict[str, Any] = {"spec": result.spec, "named": named, "run": gaps(result.before[0], result.after[0])}
    if args.held_out is not None:
        other = read_run(args.held_out)
        out["held_out"] = gaps(replay_gap(other, spec), replay_gap(other, result.spec))
    return out
