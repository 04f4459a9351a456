"""Options shared by several commands: the FE force history and its symmetry declaration, the ideal path, and the
sheet force model."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from twin.errors import InputError
from twin.process.forces import ForceHistory, default_force_history, load_force_history
from twin.process.isf_calibration import isf_field_factory
from twin.process.path import ToolPath, groove_path, label_passes
from twin.process.placement import Placement
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


FORCE_MODELS = ("auto", "table", "isf")


def add_force_model_argument(parser: argparse.ArgumentParser) -> None:
    """Add `--force-model auto|table|isf` (the sheet force model of the twin or lab)."""
    parser.add_argument(
        "--force-model",
        choices=FORCE_MODELS,
        default="auto",
        help="sheet force model: 'table' the per-pass field of the groove's FE history, 'isf' the height-map ISF "
        "model (any part); 'auto' (default) takes 'table' when the path is the history's groove, else 'isf'",
    )


def field_factory_for(
    choice: str, history: ForceHistory, p_sheet_m: Any
) -> Callable[[ForceHistory], Any] | None:
    """The `Twin(field_factory=...)` for `--force-model` and a path; None is the per-pass table field.

    `auto` keeps the table field when the path runs along the history's groove (y within 1 mm of the centre line
    and no more passes than the history has), and takes the ISF height-map model otherwise.
    """
    if choice == "table":
        return None
    if choice == "isf":
        return isf_field_factory()
    path_m = np.asarray(p_sheet_m, dtype=float)
    passes, _ = label_passes(path_m[:, 0])
    history_passes, _ = label_passes(history.p_sheet_m[:, 0])
    along_groove = float(np.max(np.abs(path_m[:, 1]))) < 1e-3 and int(passes.max()) <= int(history_passes.max())
    return None if along_groove else isf_field_factory()


def add_placement_arguments(parser: argparse.ArgumentParser | Any, title: str = "sheet placement") -> Any:
    """Add `--origin-mm X Y Z` and `--yaw-deg` (the sheet frame in the robot base); returns their group."""
    place = parser.add_argument_group(title)
    place.add_argument(
        "--origin-mm",
        type=float,
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="sheet origin in the robot base frame [mm] (default: the cell's sheet_origin)",
    )
    place.add_argument("--yaw-deg", type=float, default=0.0, help="sheet yaw about the base z axis [deg] (default 0)")
    return place


def placement_from(args: argparse.Namespace) -> Placement:
    """The `Placement` of `--origin-mm` / `--yaw-deg`."""
    origin = None if args.origin_mm is None else (args.origin_mm[0] / 1e3, args.origin_mm[1] / 1e3, args.origin_mm[2] / 1e3)
    return Placement(origin_base_m=origin, yaw_rad=math.radians(args.yaw_deg))
