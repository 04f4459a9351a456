"""`tx200-twin calibrate`: fit the twin's free physical parameters to the thesis's measurements."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, TextIO

from twin.base.jsonio import emit_json
from twin.cli._common import add_json_argument

if TYPE_CHECKING:
    from twin.analysis.calibration.loo import LeaveOneOut

HELP = "Calibrate K_q, joint friction and the sheet's sensitivities to the thesis's measured numbers."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--json FILE` (`-` for stdout) and `--quiet`."""
    add_json_argument(parser, "the calibration")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    parser.add_argument(
        "--loo", action="store_true",
        help="also refit once per target without it and predict it (leave-one-out; about 3 minutes on 2 cores)",
    )


def run(args: argparse.Namespace) -> int:
    """Run the least-squares calibration (about 1–4 minutes on 2 cores) and report it."""
    from twin.analysis.calibration.fit import PARAMETERS, calibrate
    from twin.analysis.calibration.targets import TARGETS

    out = sys.stderr if args.json == "-" else sys.stdout

    def progress(count: int, cost: float) -> None:
        if not args.quiet and count % 10 == 0:
            print(f"  {count} twin evaluations, cost {cost:.3f}", file=out, flush=True)

    cal = calibrate(progress=progress)
    dof = len(TARGETS) - len(PARAMETERS)
    print(f"calibration: {cal.evaluations} evaluations, reduced chi2 {cal.chi2_reduced:.2f} ({len(TARGETS)} targets, "
          f"{len(PARAMETERS)} parameters: {dof} degrees of freedom)", file=out)
    for name in PARAMETERS:
        print(f"  {name:18s} {cal.values[name]:12.5g} ± {cal.sigma[name]:.2g}", file=out)
    print("  target             thesis       twin   (twin-thesis)/sigma", file=out)
    for row in cal.residuals():
        print(
            f"  {row['target']:16s} {row['thesis']:9.3f} {row['twin']:10.3f}   {row['normalised']:+.2f}",
            file=out,
        )
    loo = _leave_one_out(args, out) if args.loo else None
    emit_json(
        args.json,
        {
            "targets_count": len(TARGETS),
            "degrees_of_freedom": dof,
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
            **({} if loo is None else {"leave_one_out": [p._asdict() for p in loo.predictions]}),
        },
    )
    return 0


def _leave_one_out(args: argparse.Namespace, out: TextIO) -> LeaveOneOut:
    """The leave-one-out refits, printed as a table."""
    from twin.analysis.calibration.loo import leave_one_out

    def progress(name: str) -> None:
        if not args.quiet:
            print(f"  leave-one-out: refit without {name}", file=out, flush=True)

    loo = leave_one_out(progress=progress)
    print("  target             thesis     fitted  predicted (left out)", file=out)
    for p in loo.predictions:
        note = f"   {', '.join(p.sole)} held at its prior: not a prediction" if p.sole else ""
        print(f"  {p.target:16s} {p.thesis:9.3f} {p.fitted:10.3f} {p.predicted:10.3f}{note}", file=out)
    return loo
