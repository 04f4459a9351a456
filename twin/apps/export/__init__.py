"""Export: a compensated path as a robot program or point list (the output edge of the twin).

Takes a path CSV (`t_s, x_mm, y_mm, z_mm`, sheet frame); gives a Stäubli VAL3 application (`val3`), a KUKA
KRL `.src`/`.dat` pair (`krl`), an ABB RAPID module (`rapid`), G-code (`gcode`) or a point list (`points_csv`),
each with the tool and the sheet frame in its header and the feed taken from the path (`program`). A robot
program carries the arm configuration of the robot's IK solution (`configuration`); `val3_check` checks the VAL3
application's grammar.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from twin.apps.export import gcode, krl, points_csv, rapid, val3
from twin.apps.export.program import (
    CellSetup,
    ProgramPath,
    default_cell,
    load_program_path,
    with_configuration,
)
from twin.errors import InputError
from twin.robot.description import RobotDescription

Writer = Callable[[ProgramPath, Path, Sequence[Path]], list[Path]]

FORMATS: dict[str, Writer] = {
    "val3": val3.write,
    "krl": krl.write,
    "rapid": rapid.write,
    "gcode": gcode.write,
    "csv": points_csv.write,
}
#: The formats that are a controller's language (`RobotDescription.language`): they carry the arm configuration.
LANGUAGES: dict[str, str] = {"val3": "VAL3", "krl": "KRL", "rapid": "RAPID"}


def robot_format(robot: RobotDescription) -> str:
    """The format of a robot's own language (VAL3 for Stäubli, KRL for KUKA, RAPID for ABB).

    Raises:
        InputError: No exporter writes the robot's language (names the robot, its language and the formats).
    """
    for fmt, language in LANGUAGES.items():
        if language == robot.language:
            return fmt
    raise InputError(
        f"robot {robot.name!r} runs {robot.language!r}, which no exporter writes; expected --format one of "
        f"{sorted(FORMATS)}"
    )


def export_path(
    path_csv: str | Path, fmt: str, out: str | Path, *, cell: CellSetup | None = None
) -> tuple[ProgramPath, list[Path]]:
    """Export a path CSV in one of `FORMATS`.

    Args:
        path_csv: The path (sheet frame).
        fmt: A key of `FORMATS`.
        out: Output file (KRL: the `.src`, its `.dat` goes beside it; VAL3: the application folder).
        cell: Frame, tool and robot; default the default robot's cell.

    Returns:
        The exported path (with its arm configurations for a robot language) and the files written.

    Raises:
        InputError: Unknown format, a bad path, or (robot languages) a path whose arm configuration changes.
        UnreachableError, SingularityError: (robot languages) a point the robot cannot reach.
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown export format {fmt!r}; expected one of {sorted(FORMATS)}")
    out = Path(out)
    path = load_program_path(path_csv, cell or default_cell(), out.stem if fmt != "val3" else out.name)
    if fmt in LANGUAGES:
        path = with_configuration(path, LANGUAGES[fmt])
    return path, FORMATS[fmt](path, out, [Path(path_csv)])
