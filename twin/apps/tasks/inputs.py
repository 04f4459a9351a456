"""Inputs several tasks declare the same way: the FE force history with its symmetry (`HistoryDeclaration`, the
CLI's `--history FILE --symmetry half|full [--unchecked-symmetry]`) and the ideal path U_ID read from a file
(`ideal_path`, the CLI's `--ideal FILE`). Their messages name the CLI's options, so a script and the command line
are refused alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from twin.errors import InputError
from twin.process.fe.load import ForceHistory, default_force_history, load_force_history
from twin.process.toolpath.groove import ToolPath, groove_path, label_passes
from twin.runs.read import read_commanded_csv

SYMMETRIES = ("half", "full")


@dataclass(frozen=True)
class HistoryDeclaration:
    """An FE force history as declared: the file and its symmetry, or neither (the shipped stand-in).

    Attributes:
        path: An FE force history CSV, or None for the shipped stand-in (`default_force_history`).
        symmetry: "half" (a half-symmetric FE model: its forces are doubled) or "full"; required with `path`.
        unchecked: Skip the column-name check of `symmetry` (only to reproduce the thesis's mistake).

    Raises:
        InputError: A symmetry without a file, a file without a symmetry, a symmetry other than half or full.
    """

    path: Path | None = None
    symmetry: str | None = None
    unchecked: bool = False

    def __post_init__(self) -> None:
        if self.symmetry is not None and self.symmetry not in SYMMETRIES:
            raise InputError(f"--symmetry {self.symmetry!r}: expected one of {', '.join(SYMMETRIES)}")
        if self.path is None and self.symmetry is not None:
            raise InputError("--symmetry is only meaningful with --history FILE")
        if self.path is not None and self.symmetry is None:
            raise InputError(
                f"--history {self.path} needs --symmetry half|full: a half-symmetric FE model's forces must be "
                "doubled (thesis sec. 2.2); forgetting it broke the thesis's compensated run (sec. 5.1)"
            )

    def load(self) -> tuple[ForceHistory, ForceHistory]:
        """The history as declared, and the physical reference (symmetry implied by the column names).

        Returns:
            (declared, reference): equal unless `unchecked` let a contradicting declaration through.

        Raises:
            SymmetryError: The column names contradict the symmetry (unless `unchecked`).
            DataFileError: A bad history file (naming the file and row).
        """
        if self.path is None or self.symmetry is None:
            history = default_force_history()
            return history, history
        declared = load_force_history(self.path, symmetry=self.symmetry, trust_columns=not self.unchecked)
        if declared.column_symmetry == declared.symmetry:
            return declared, declared
        return declared, load_force_history(self.path, symmetry=declared.column_symmetry)


def ideal_path(path: Path | None = None) -> ToolPath:
    """The ideal path U_ID: a CSV `t_s, x_mm, y_mm, z_mm` (sheet frame), its passes labelled by its x reversals,
    or the thesis groove when `path` is None.

    Raises:
        DataFileError: A bad path file (naming the file and row).
    """
    if path is None:
        return groove_path()
    stream = read_commanded_csv(path)
    pass_index, direction = label_passes(stream.values[:, 0])
    return ToolPath(t_s=stream.t_s, p_sheet_m=stream.values, pass_index=pass_index, direction=direction)
