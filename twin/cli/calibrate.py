"""`tx200-twin calibrate`: fit the twin's free physical parameters to the thesis's measurements."""

from __future__ import annotations

import argparse
import sys

from twin.base.csvio import emit_json

HELP = "Calibrate K_q, joint friction and the sheet's sensitivities to the thesis's measured numbers."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--json FILE` (`-` for stdout) and `--quiet`."""
    parser.add_argument("--json", metavar="FILE", help="write the calibration as JSON ('-' = stdout)")
    parser.add_argument("--quiet", action="store_true", help="no progress output")


def run(args: argparse.Namespace) -> int:
    """Run the least-squares calibration (about 1–4 minutes on 2 cores) and report it."""
    from twin.analysis.calibration.fit import PARAMETERS, calibrate

    out = sys.stderr if args.json == "-" else sys.stdout

    def progress(count: int, cost: float) -> None:
        if not args.quiet and count % 10 == 0:
            print(f"  {count} twin evaluations, cost {cost:.3f}", file=out, flush=True)

    cal = calibrate(progress=progress)
    print(f"calibration: {cal.evaluations} evaluations, reduced chi2 {cal.chi2_reduced:.2f}", file=out)
    for name in PARAMETERS:
        print(f"  {name:18s} {cal.values[name]:12.5g} ± {cal.sigma[name]:.2g}", file=out)
    print("  target             thesis       twin   (twin-thesis)/sigma", file=out)
    for row in cal.residuals():
        print(
            f"  {row['target']:16s} {row['thesis']:9.3f} {row['twin']:10.3f}   {row['normalised']:+.2f}",
            file=out,
        )
    emit_json(
        args.json,
        {
            "parameters": cal.values,
            "sigma": cal.sigma,
            "start": cal.start,
            "chi2_reduced": cal.chi2_reduced,
            "evaluations": cal.evaluations,
            "targets": cal.residuals(),
            "k_r1_n_per_mm": cal.measurements.k_r1_n_per_mm,
            "cr1_mm_per_kn": cal.measurements.cr1_mm_per_kn,
            "k_r2_n_per_mm": cal.measurements.k_r2_n_per_mm,
            "cr2_mm_per_kn": cal.measurements.cr2_mm_per_kn,
            "method2_force_drop": cal.measurements.force_drop,
        },
    )
    return 0
