"""The command line, called from the experiments with its output captured."""

from __future__ import annotations

import argparse
import json
from contextlib import redirect_stdout
from io import StringIO
from pathlib import Path
from typing import Any

from twin.cli import main


def cli(*argv: str) -> None:
    """Run `tx200-twin ARGV`, quiet; a non-zero exit ends the experiment naming the command."""
    with redirect_stdout(StringIO()):
        code = main(list(argv))
    if code != 0:
        raise SystemExit(f"`tx200-twin {' '.join(argv)}` exited with {code}")


def cli_json(*argv: str) -> dict[str, Any]:
    """Run `tx200-twin ARGV --json -` and return its document (`check`'s exit 1 included)."""
    out = StringIO()
    with redirect_stdout(out):
        code = main([*argv, "--json", "-"])
    if code not in (0, 1):
        raise SystemExit(f"`tx200-twin {' '.join(argv)}` exited with {code}")
    return dict(json.loads(out.getvalue()))


def add_tracker_options(parser: argparse.ArgumentParser) -> None:
    """`learn`'s tracker options, one at most: `--tracker-errors` (its turn and lateness beside the robot) or
    `--tracker-late` (its lateness alone); `tracker_options` gives them back as `learn` arguments."""
    tracker = parser.add_mutually_exclusive_group()
    tracker.add_argument("--tracker-errors", action="store_true", help="learn with `learn --tracker-errors`")
    tracker.add_argument("--tracker-late", action="store_true", help="learn with `learn --tracker-late`")


def tracker_options(args: argparse.Namespace) -> tuple[str, ...]:
    """The `learn` arguments of `add_tracker_options`' options as given."""
    return ("--tracker-errors",) if args.tracker_errors else ("--tracker-late",) if args.tracker_late else ()


def write_between_markers(doc: Path, marker: str, text: str) -> None:
    """Replace what lies between a page's `<!-- MARKER:begin ... -->` line and its `<!-- MARKER:end -->` by `text`
    (a generated table)."""
    page = doc.read_text(encoding="utf-8")
    begin = page.index("\n", page.index(f"<!-- {marker}:begin")) + 1
    end = page.index(f"<!-- {marker}:end")
    doc.write_text(page[:begin] + text + page[end:], encoding="utf-8")


def write_study(out: Path, stem: str, rows: list[dict[str, Any]], table: str, doc: Path | None, marker: str) -> None:
    """A study's outputs: OUT/STEM.json (its rows), OUT/STEM.md (its `table`), the table printed, and with `doc` the
    table between the page's `marker` markers."""
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{stem}.json").write_text(json.dumps(rows, indent=1))
    (out / f"{stem}.md").write_text(table)
    print(table)
    if doc is not None:
        write_between_markers(doc, marker, table)


def lab_neutral(robot: str, program: Path, out: Path, seed: int, scenario: str = "nominal",
                plant_set: tuple[str, ...] = ()) -> Path:
    """Form `program` on the dynamic plant with neutral knobs and `plant_set` (NAME=VALUE) into `out`, replacing an
    earlier run there (`lab --plant dynamic --neutral`)."""
    cli("lab", "--plant", "dynamic", "--neutral", *(a for item in plant_set for a in ("--set", item)), "--robot", robot,
        "--scenario", scenario, "--commanded", str(program), "--seed", str(seed), "--out", str(out), "--overwrite")
    return out
