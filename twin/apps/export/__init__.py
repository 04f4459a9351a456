"""Export: a compensated path as a robot program or point list (the output edge of the twin).

Takes a path CSV (`t_s, x_mm, y_mm, z_mm`, sheet frame); gives a Stäubli VAL3 application (`val3`), a KUKA
KRL `.src`/`.dat` pair (`krl`), an ABB RAPID module (`rapid`), G-code (`gcode`) or a point list (`csv`),
each with the tool and the sheet frame in its header and the feed taken from the path.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from twin.apps.export import gcode, krl, points_csv, rapid, val3
from twin.apps.export.program import CellSetup, ProgramPath, default_cell, load_program_path
from twin.errors import InputError

Writer = Callable[[ProgramPath, Path, Sequence[Path]], list[Path]]

FORMATS: dict[str, Writer] = {
    "val3": val3.write,
    "krl": krl.write,
    "rapid": rapid.write,
    "gcode": gcode.write,
    "csv": points_csv.write,
}


def export_path(
    path_csv: str | Path, fmt: str, out: str | Path, *, cell: CellSetup | None = None
) -> tuple[ProgramPath, list[Path]]:
    """Export a path CSV in one of `FORMATS`.

    Args:
        path_csv: The path (sheet frame).
        fmt: A key of `FORMATS`.
        out: Output file (KRL: the `.src`, its `.dat` goes beside it; VAL3: the application folder).
        cell: Frame and tool; default the thesis cell.

    Returns:
        The exported path and the files written.
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown export format {fmt!r}; expected one of {sorted(FORMATS)}")
    out = Path(out)
    path = load_program_path(path_csv, cell or default_cell(), out.stem if fmt != "val3" else out.name)
    return path, FORMATS[fmt](path, out, [Path(path_csv)])
