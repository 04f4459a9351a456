"""`tx200-twin replay`: simulate a run's commanded path on the twin and compare with its measurements."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from twin.base.jsonio import emit_json
from twin.cli._common import (
    add_force_model_argument,
    add_json_argument,
    add_process_arguments,
    add_robot_argument,
    spec_from_arguments,
)
from twin.errors import InputError
from twin.process.process_file import process_record
from twin.runs.read import read_run

HELP = "Replay a measured run on the twin and report the gap (position and force)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `replay` options."""
    parser.add_argument("run_dir", type=Path, help="a tx200-twin-run/1 directory")
    parser.add_argument(
        "--model", type=Path, help="twin model file (effects, K_q, process) from `discrepancy --model-out`"
    )
    add_force_model_argument(parser)
    add_process_arguments(parser)
    add_robot_argument(parser)
    parser.add_argument("--forces", choices=("twin", "measured"), default="twin",
                        help="measured: also drive the twin's robot by the run's F/T stream and split the gap into "
                        "the robot's part and the sheet's part")
    add_json_argument(parser, "the metrics")
    parser.add_argument("--rrd", type=Path, help="also save a rerun recording of the replay to FILE")


def run(args: argparse.Namespace) -> int:
    """Replay the run."""
    from twin.analysis.replay import replay

    measured = read_run(args.run_dir)
    spec = spec_from_arguments(args, measured.commanded.values, run=measured)
    twin = spec.build()
    result = replay(measured, twin)
    m = result.metrics
    out = sys.stderr if args.json == "-" else sys.stdout  # keep stdout pure JSON for `--json -`
    print(
        f"replay {args.run_dir}: {m['samples']} tracker samples; "
        f"position gap rms {m['position_rms_mm']:.3f} mm (max {m['position_max_mm']:.3f}); "
        f"force gap rms {m.get('force_rms_n', float('nan')):.1f} N "
        f"(max {m.get('force_max_n', float('nan')):.1f}); "
        f"measured deflection max {m['deflection_max_mm']:.2f} mm; process {spec.process.material}, "
        f"{1e3 * spec.process.thickness_m:g} mm, {spec.process.force_model} model",
        file=out,
    )
    if args.forces == "measured":
        from twin.analysis.learn.split import split_gap

        if measured.forces is None:
            raise InputError(f"run {args.run_dir} has no forces.csv: --forces measured needs the F/T stream")
        split = split_gap(measured, twin, result)
        m = {**m, "robot_gap_rms_mm": split.robot_rms_mm, "sheet_gap_rms_mm": split.sheet_rms_mm}
        print(f"  split: the robot's part (the twin's robot driven by the measured forces) {split.robot_rms_mm:.3f} "
              f"mm rms; the sheet's part (what the twin's forces move the tip by) {split.sheet_rms_mm:.3f} mm rms",
              file=out)
    if args.rrd is not None:
        from twin.viz.recording import record_replay

        record_replay(args.rrd, measured, result, twin_model=twin.model, placement=twin.placement)
        print(f"rerun recording -> {args.rrd}", file=out)
    process = {**process_record(spec.process), "force_model": spec.process.force_model}
    protect = [p for p in (args.run_dir, args.model, args.process) if p is not None]
    emit_json(args.json, {"run": args.run_dir, **m, "process": process}, protect=protect)
    return 0
