"""Options shared by several commands: the FE force history and its symmetry declaration, the ideal path."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.errors import InputError
from twin.process.forces import ForceHistory, default_force_history, load_force_history
from twin.process.path import ToolPath, groove_path, label_passes
from twin.runs.read import read_commanded_csv


def add_history_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--history FILE --symmetry half|full [--unchecked-symmetry]`."""
    parser.add_argument("--history", type=Path, help="FE force history CSV (default: the shipped stand-in)")
    parser.add_argument(
        "--symmetry",
        choices=("half", "full"),
        help="REQUIRED with --history: half-symmetric or full FE model",
    )
    parser.add_argument(
        "--unchecked-symmetry",
        action="store_true",
        help="skip the column-name check of --symmetry (only to reproduce the thesis's mistake)",
    )


def history_from_arguments(args: argparse.Namespace) -> tuple[ForceHistory, ForceHistory]:
    """The history as declared, and the physical reference (symmetry implied by the column names).

    Returns:
        (declared, reference): equal unless `--unchecked-symmetry` let a contradicting declaration through.
    """
    if args.history is None:
        if args.symmetry is not None:
            raise InputError("--symmetry is only meaningful with --history FILE")
        history = default_force_history()
        return history, history
    if args.symmetry is None:
        raise InputError(
            f"--history {args.history} needs --symmetry half|full: a half-symmetric FE model's forces must be "
            "doubled (thesis sec. 2.2); forgetting it broke the thesis's compensated run (sec. 5.1)"
        )
    declared = load_force_history(
        args.history, symmetry=args.symmetry, trust_columns=not args.unchecked_symmetry
    )
    if declared.column_symmetry == declared.symmetry:
        return declared, declared
    return declared, load_force_history(args.history, symmetry=declared.column_symmetry)


def add_ideal_argument(parser: argparse.ArgumentParser) -> None:
    """Add `--ideal FILE` (the ideal path U_ID; default: the thesis groove)."""
    parser.add_argument(
        "--ideal", type=Path, help="ideal path U_ID as CSV t_s,x_mm,y_mm,z_mm (default: the groove)"
    )


def ideal_from_arguments(args: argparse.Namespace) -> ToolPath:
    """The ideal path U_ID from `--ideal` or the default groove."""
    if args.ideal is None:
        return groove_path()
    stream = read_commanded_csv(args.ideal)
    pass_index, direction = label_passes(stream.values[:, 0])
    return ToolPath(t_s=stream.t_s, p_sheet_m=stream.values, pass_index=pass_index, direction=direction)
