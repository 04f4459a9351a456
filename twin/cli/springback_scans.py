"""`tx200-twin springback-scans`: the formed part's springback held to 32 scanned SPIF cones and the BM3 cone."""

import argparse
from pathlib import Path

from twin.cli._common import add_json_argument

HELP = "Form 16 scanned cones' conditions and the BM3 cone rigidly; fit the wall's tilt on two angles, predict the rest."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `springback-scans` options."""
    parser.add_argument("--markdown", type=Path, help="write the page (docs/springback.md) to FILE")
    add_json_argument(parser, "the fitted constants, the rows and the BM3 cone")


def run(args: argparse.Namespace) -> int:
    """Study, print the page, write it where asked (`twin.apps.springback_page.run`)."""
    from twin.apps.springback_page import run as study
    return study(args.markdown, args.json)
