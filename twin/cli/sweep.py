"""`tx200-twin sweep`: Monte Carlo of the model's uncertainty -> distribution of the compensated residual."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from twin.base.jsonio import emit_json
from twin.cli._common import (
    add_history_arguments,
    add_ideal_argument,
    add_json_argument,
    add_scheduler_argument,
    history_from_arguments,
    ideal_from_arguments,
)
from twin.cli._types import count, seed
from twin.process.description import Process
from twin.sim.spec import TwinSpec

HELP = "Monte Carlo of K_q / friction / sheet / force-scale uncertainty: distribution of the compensated residual."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `sweep` options."""
    parser.add_argument("--draws", type=count, default=200, help="parameter sets to replay (default 200)")
    parser.add_argument("--seed", type=seed, default=0, help="seed of the draws (default 0)")
    parser.add_argument("--workers", type=count, help="worker processes (default: every usable core)")
    add_scheduler_argument(parser)
    parser.add_argument(
        "--calibration", type=Path,
        help="calibration JSON with 'parameters' and 'sigma' (tx200-twin calibrate, e.g. docs/calibration.json); "
        "default: the model's values with the relative sigma of twin.apps.uncertainty.DEFAULT_RELATIVE_SIGMA",
    )
    parser.add_argument("--uncompensated", action="store_true", help="replay the ideal path, not its compensation")
    add_history_arguments(parser)
    add_ideal_argument(parser)
    parser.add_argument("--figure", type=Path, help="write the distribution figure (PNG) to FILE")
    add_json_argument(parser, "the results")


def run(args: argparse.Namespace) -> int:
    """Run the sweep with a progress bar on stderr."""
    from twin.apps.sweep import run_sweep
    from twin.apps.sweep_figure import sweep_figure

    history, _ = history_from_arguments(args)
    ideal = ideal_from_arguments(args)
    start = time.perf_counter()

    def progress(done: int, total: int) -> None:
        filled = round(30 * done / total)
        print(f"\rsweep [{'#' * filled}{'.' * (30 - filled)}] {done}/{total} draws, "
              f"{time.perf_counter() - start:.1f} s", end="\n" if done == total else "", file=sys.stderr, flush=True)

    result = run_sweep(
        args.draws, spec=TwinSpec(process=Process(history=history)), seed=args.seed, workers=args.workers,
        calibration=args.calibration, path=ideal, compensate=not args.uncompensated, progress=progress,
        scheduler=args.scheduler,
    )
    summary = result.summary()
    if args.figure is not None:
        summary["figure"] = str(sweep_figure(result, args.figure))
    rms = summary["rms_mm"]
    print(
        f"sweep: {summary['draws']} draws on {summary['workers']} workers in {summary['wall_s']:.1f} s "
        f"({summary['replays_per_s_per_core']:.1f} replays/s/core); RMS residual median {rms['p50']:.4f} mm "
        f"(5-95 %: {rms['p5']:.4f}-{rms['p95']:.4f} mm, nominal model {summary['nominal_rms_mm']:.4f} mm)",
        file=sys.stderr if args.json == "-" else sys.stdout,
    )
    protect = [p for p in (args.calibration, args.history, args.ideal) if p is not None]
    emit_json(args.json, summary, protect=protect)
    return 0
