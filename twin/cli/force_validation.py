"""`tx200-twin force-validation`: the force model against published measurements of ISF forces."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from twin.cli._common import add_json_argument
from twin.cli._types import seed

HELP = "Form every published ISF force measurement's part on the rigid machine; tabulate measured vs model."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `force-validation` options."""
    parser.add_argument("--markdown", type=Path, help="write the page (docs/force-validation.md) to FILE")
    add_json_argument(parser, "the rows")
    parser.add_argument("--seed", type=seed, default=1, help="seed of the rigid machine's sensor noise (default 1)")


def run(args: argparse.Namespace) -> int:
    """Validate, print the table, write it where asked."""
    from twin.apps.force_validation import markdown, result_json, validate_forces
    from twin.base.csvio import write_text
    from twin.base.jsonio import emit_json

    result = validate_forces(seed=args.seed)
    text = markdown(result)
    if args.markdown is not None:
        write_text(args.markdown, text)
    print(text, file=sys.stderr if args.json == "-" else sys.stdout)
    emit_json(args.json, result_json(result))
    return 0
