"""Export: a compensated path as a robot program or point list (the output edge of the twin).

Takes a path CSV (`t_s, x_mm, y_mm, z_mm`, sheet frame); gives a Stäubli VAL3 application (`val3`), a KUKA
KRL `.src`/`.dat` pair (`krl`), ABB RAPID modules with their `.pgf` (`rapid`: an entry procedure `isf_NAME`, no
`main`), G-code (`gcode`) or a point list (`points_csv`),
each with the tool and the sheet frame in its header and the feed taken from the path (`program`). Every program
approaches from a safe height and retracts to it, its feeds limited to the process feed in contact (`motion`);
every point is checked for reach (`reach`); a program over its controller's size limit is split into parts that a
main program calls (`parts`). A robot program carries the arm configuration of the robot's IK solution
(`configuration`); `val3_check` (with `val3_data_check`) checks the VAL3 application's grammar; for
`export --online`, `krl_rsi` writes KRL with the online correction of KUKA RSI switched on and its Ethernet configuration, `rapid_egm` RAPID with ABB EGM
path correction in the path's moves (48 ms, y and z of the path frame only; a lost PC stops and lifts the tool) and
its UDP device and motion profile configurations, `rapid_egm_pose` RAPID with EGM position guidance (the PC
streams the path and the correction, every axis every 4 ms; `export --online`'s ABB default) and its guidance
table, `val3_alter` the VAL3
application with `alter` moves and a synchronous task that takes the twin's correction over a socket.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

from twin.apps.export import (
    gcode,
    krl,
    krl_rsi,
    points_csv,
    rapid,
    rapid_egm,
    rapid_egm_pose,
    val3,
    val3_alter,
)
from twin.apps.export.motion import FeedSummary, with_moves
from twin.apps.export.program import (
    DEFAULT_BASE_NUMBER,
    DEFAULT_TOOL_NUMBER,
    CellSetup,
    ProgramPath,
    check_reach,
    default_cell,
    load_program_path,
    program_name,
    with_configuration,
)
from twin.base.registry import Registry
from twin.errors import InputError
from twin.robot.facts import RobotDescription
from twin.sim.online_settings import OnlineSettings, check_max_correction_mm

Writer = Callable[[ProgramPath, Path, Sequence[Path]], list[Path]]


class ExportFormat(NamedTuple):
    """One export format.

    Attributes:
        name: The `--format` choice.
        write: Writes the program of a `ProgramPath` to an output stem, never over the protected inputs; returns
            the files written.
        language: The controller language it is (`RobotDescription.language`), or None (G-code, a point list):
            a language's program carries the arm configuration.
        online: The program switches the twin's online correction on (`export --online`, `online --serve`).
    """

    name: str
    write: Writer
    language: str | None = None
    online: bool = False


#: The export formats, by name (`twin.base.registry.Registry`).
EXPORT_FORMATS: Registry[ExportFormat] = Registry("export format")
for _format in (ExportFormat("val3", val3.write, "VAL3"), ExportFormat("krl", krl.write, "KRL"),
                ExportFormat("rapid", rapid.write, "RAPID"), ExportFormat("gcode", gcode.write),
                ExportFormat("csv", points_csv.write), ExportFormat("krl-rsi", krl_rsi.write, "KRL", online=True),
                ExportFormat("rapid-egm", rapid_egm.write, "RAPID", online=True),
                ExportFormat("val3-alter", val3_alter.write, "VAL3", online=True),
                ExportFormat("rapid-egm-pose", rapid_egm_pose.write, "RAPID", online=True)):
    EXPORT_FORMATS.register(_format)


class _Writers(Mapping[str, Writer]):
    """Format name -> writer, over the registry (what `FORMATS` was)."""

    def __getitem__(self, name: str) -> Writer:
        return EXPORT_FORMATS[name].write

    def __iter__(self) -> Iterator[str]:
        return iter(EXPORT_FORMATS)

    def __len__(self) -> int:
        return len(EXPORT_FORMATS)


class _Languages(Mapping[str, str]):
    """Format name -> controller language, for the formats that are one (what `LANGUAGES` was)."""

    def __getitem__(self, name: str) -> str:
        language = EXPORT_FORMATS[name].language
        if language is None:
            raise KeyError(name)
        return language

    def __iter__(self) -> Iterator[str]:
        return (name for name, fmt in EXPORT_FORMATS.items() if fmt.language is not None)

    def __len__(self) -> int:
        return sum(1 for _ in self)


FORMATS: Mapping[str, Writer] = _Writers()
#: The formats that are a controller's language (`RobotDescription.language`): they carry the arm configuration.
LANGUAGES: Mapping[str, str] = _Languages()


def online_format(robot: RobotDescription) -> str:
    """The format of a robot's program with the twin's online correction (KUKA: KRL with RSI; ABB: RAPID with EGM;
    Stäubli: VAL3 with alter).

    Raises:
        InputError: No online format writes its language (names the robot, its language and those written).
    """
    online = [f for f in EXPORT_FORMATS.values() if f.online]
    for fmt in online:
        if fmt.language == robot.language:
            return fmt.name
    raise InputError(f"robot {robot.name!r} runs {robot.language!r}: export --online writes "
                     f"{', '.join(f'{f.language} ({f.name})' for f in online)} only; expected a robot that runs "
                     "one of those")


def robot_format(robot: RobotDescription) -> str:
    """The format of a robot's own language (VAL3 for Stäubli, KRL for KUKA, RAPID for ABB).

    Raises:
        InputError: No exporter writes the robot's language (names the robot, its language and the formats).
    """
    for fmt in EXPORT_FORMATS.values():
        if fmt.language == robot.language and not fmt.online:
            return fmt.name
    raise InputError(
        f"robot {robot.name!r} runs {robot.language!r}, which no exporter writes; expected --format one of "
        f"{sorted(FORMATS)}"
    )


class Exported(NamedTuple):
    """What `export_path` wrote.

    Attributes:
        path: The program (approach, path, retract; with its arm configurations for a robot language).
        files: The files written.
        feeds: The feeds in contact and the safe height.
    """

    path: ProgramPath
    files: list[Path]
    feeds: FeedSummary


def export_path(
    path_csv: str | Path,
    fmt: str,
    out: str | Path,
    *,
    cell: CellSetup | None = None,
    safe_z_mm: float | None = None,
    process_feed_mm_s: float | None = None,
    max_points: int = 0,
    tool_number: int = DEFAULT_TOOL_NUMBER,
    base_number: int = DEFAULT_BASE_NUMBER,
    max_correction_mm: float = OnlineSettings.max_correction_mm,
) -> Exported:
    """Export a path CSV in one of `FORMATS`.

    Args:
        path_csv: The path (sheet frame).
        fmt: A key of `FORMATS`.
        out: Output file (KRL: the `.src`, its `.dat` goes beside it; VAL3: the application folder).
        cell: Frame, tool and robot; default the default robot's cell.
        safe_z_mm: Approach and retract height, sheet frame z [mm]; None: `motion.default_safe_z_mm`.
        process_feed_mm_s: The process feed [mm/s]; None: the median of the path's feeds.
        max_points: Points per file before a program is split (`parts`); 0: the format's limit.
        tool_number: The controller's tool (and load) slot a KRL program writes and uses (`twin.robot.controller.TOOL_NUMBERS`).
        base_number: The controller's base slot a KRL program writes and uses (`twin.robot.controller.BASE_NUMBERS`).
        max_correction_mm: An online program's limit on the correction [mm] (`ProgramPath.max_correction_mm`).

    Returns:
        The exported program, the files written and the feed summary.

    Raises:
        InputError: Unknown format, a bad path, a VAL3 folder name VAL3 does not take, a safe height below the path,
            or (robot languages) a path whose arm configuration changes.
        UnreachableError, SingularityError: A point the robot cannot reach (named with its row and distance).
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown export format {fmt!r}; expected one of {sorted(FORMATS)}")
    out = Path(out)
    folder = EXPORT_FORMATS[fmt].language == "VAL3"  # a VAL3 application is a folder named as the application
    name = out.name if folder else out.stem
    path = load_program_path(path_csv, cell or default_cell(), name)  # the input first: its errors come first
    if folder and program_name(name) != name:
        raise InputError(
            f"--out {out}: a VAL3 application's folder is its name, and VAL3 names are letters, digits and _, "
            f"starting with a letter, at most 24 characters; {name!r} is not one (expected e.g. "
            f"{out.with_name(program_name(name))})"
        )
    path, feeds = with_moves(path, safe_z_mm, process_feed_mm_s)
    path = replace(path, max_points=max_points, tool_number=tool_number, base_number=base_number,
                   max_correction_mm=check_max_correction_mm(max_correction_mm))
    if fmt in LANGUAGES:
        path = with_configuration(path, LANGUAGES[fmt])
    else:
        check_reach(path)
    return Exported(path, FORMATS[fmt](path, out, [Path(path_csv)]), feeds)
