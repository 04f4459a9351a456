"""`tx200-twin fe-history`: regenerate the stand-in FE force history CSV (see twin.process.fe.generator)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from twin.base.jsonio import emit_json
from twin.cli._common import add_json_argument
from twin.process.fe.generator import write_history
from twin.process.fe.load import load_force_history

HELP = "Regenerate the stand-in half-symmetric FE force history (1311 samples) to --out."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the command's options."""
    parser.add_argument("--out", type=Path, required=True, help="output CSV file")
    add_json_argument(parser, "the summary")


def run(args: argparse.Namespace) -> int:
    """Write the history and print its physical peaks."""
    write_history(args.out)
    history = load_force_history(args.out, symmetry="half")
    f = history.f_sheet_n
    payload = {
        "out": str(args.out),
        "samples": len(history.s_m),
        "symmetry": "half",
        "peak_fx_physical_n": float(abs(f[:, 0]).max()),
        "peak_fz_physical_n": float(f[:, 2].max()),
    }
    emit_json(args.json, payload, protect=[args.out])
    out = sys.stderr if args.json == "-" else sys.stdout
    print(
        f"wrote {args.out}: {payload['samples']} samples (half-symmetric values); physical peaks "
        f"|Fx| {payload['peak_fx_physical_n']:.0f} N, Fz {payload['peak_fz_physical_n']:.0f} N",
        file=out,
    )
    return 0
