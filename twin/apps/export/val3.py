"""Stäubli VAL3 application (the thesis's robot, CS8/CS9 controllers): a point list and a program through it.

A VAL3 application is a folder of XML files (VAL3 reference manual, "Applications"): the project
`NAME.pjx`, the global data `NAME.dtx`, and one `.pgx` file per program. We write:

- `NAME.dtx`: the frame `fSheet` (sheet origin in the robot base, child of `world`), the tool `tIsf`
  (child of `flange`), the home `jHome` (`jointRx`: the robot's home keyframe in controller axis values
  `j1`..`j6` [deg], `program.home_axes_deg`; the layout of the `jPark` datum RoboDK's Stäubli post writes), the
  points `pPath[n]` (`pointRx`, children of `fSheet`: the approach point above the path,
  the path, the retract point, `twin.apps.export.motion`; the first carries the shoulder,
  elbow and wrist of the robot's IK solution, `twin.apps.export.configuration`, which the `movej` to it goes to;
  the others `ssame`/`esame`/`wsame`, as a `movel` cannot change them), one `mdesc` per point
  `mPath[n]` whose Cartesian speed `tmax` is the path's feed, and `mApproach` for the first move;
- `start.pgx`: `movej(jHome, tIsf, mApproach)` (HOME), `movej` to the approach point, `movel(pPath[i], tIsf,
  mPath[i])` down onto the path, through it and up to the retract point, `waitEndMove()` (which also ends the last
  move's blending), `movej(jHome, tIsf, mApproach)` and `waitEndMove()`: HOME is the first and the last move;
- `stop.pgx`: `resetMotion()`: when the application stops (the operator, an error) the motion commands left are
  cancelled and the arm stops, as ros-industrial `staubli_val3_driver`'s `val3/ros_server/stop.pgx` does (and
  RoboDK's VAL3 post).

The folder is the application's name: a name VAL3 does not take (`my prog-1`) is refused by `export_path` with
the name it would take (`my_prog_1`), so that the folder and its `.pjx` agree.

Every file is checked with `twin.apps.export.val3_check` before the folder is moved into place.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterable, Sequence
from pathlib import Path

from twin.apps.export.program import ProgramPath, cell_lines, euler_xyz_deg, fmt, home_axes_deg
from twin.apps.export.val3_check import check_application
from twin.base.csvio import swap_in_directory, temporary_folder
from twin.errors import InputError

XSI = "http://www.w3.org/2001/XMLSchema-instance"
NS_PROJECT = "http://www.staubli.com/robotics/VAL3/Project/3"
NS_DATA = "http://www.staubli.com/robotics/VAL3/Data/2"
NS_PROGRAM = "http://www.staubli.com/robotics/VAL3/Program/2"
BLEND_MM = 0.1  # Cartesian blending: leave/reach distance, well below the 0.5 mm point spacing
APPROACH_VEL_PERCENT = 10

START_CODE = """begin
  // {name}: {n} points of {source}, sheet frame fSheet, tool tIsf, robot {robot}
{about}  movej(jHome, tIsf, mApproach)
  movej(pPath[0], tIsf, mApproach)
  waitEndMove()
  for i = 1 to size(pPath) - 1
    movel(pPath[i], tIsf, mPath[i])
  endFor
  waitEndMove()
  movej(jHome, tIsf, mApproach)
  waitEndMove()
end"""


def _data(name: str, kind: str, values: list[str]) -> str:
    body = "\n".join(f'      <Value key="{k}" {v} />' for k, v in enumerate(values))
    return (
        f'    <Data name="{name}" access="private" xsi:type="array" type="{kind}" size="{len(values)}">\n'
        f"{body}\n    </Data>"
    )


def _pose(xyz: Iterable[float], rxyz: Iterable[float]) -> str:
    return " ".join(
        f'{k}="{fmt(v)}"' for k, v in zip(("x", "y", "z", "rx", "ry", "rz"), [*xyz, *rxyz], strict=True)
    )


def home_datum(path: ProgramPath) -> str:
    """`jHome`: the robot's home as axis values j1..j6 [deg] (a `jointRx`)."""
    axes = " ".join(f'j{i}="{fmt(v)}"' for i, v in enumerate(home_axes_deg(path.cell), start=1))
    return _data("jHome", "jointRx", [axes])


def application_files(path: ProgramPath) -> dict[str, str]:
    """The application's files: name -> XML text."""
    cell = path.cell
    r_tool = euler_xyz_deg(cell.R_sheet_tool)
    same = ("ssame", "esame", "wsame")
    first = cell.configuration.val3 if cell.configuration is not None else same
    points = [
        f'{_pose(p, r_tool)} shoulder="{s}" elbow="{e}" wrist="{w}" fatherId="fSheet[0]"'
        for p, (s, e, w) in zip(path.points_mm, [first] + [same] * (len(path.points_mm) - 1), strict=True)
    ]
    blend = f'blend="Cartesian" leave="{fmt(BLEND_MM)}" reach="{fmt(BLEND_MM)}"'
    mdesc = [
        f'accel="100" vel="100" decel="100" tmax="{fmt(v, 3)}" rmax="9999" {blend}' for v in path.feed_mm_s
    ]
    approach = f'accel="100" vel="{APPROACH_VEL_PERCENT}" decel="100" tmax="250" rmax="45" blend="off" leave="50" reach="50"'
    datas = [
        _data("fSheet", "frame", [f'{_pose(cell.p_base_sheet_mm, (0, 0, cell.yaw_deg))} fatherId="world[0]"']),
        _data(
            "tIsf",
            "tool",
            [
                f'{_pose((0, 0, cell.tool_length_mm), (0, 0, 0))} fatherId="flange[0]" ioLink="valve1" open="0" close="0"'
            ],
        ),
        home_datum(path),
        _data("mApproach", "mdesc", [approach]),
        _data("mPath", "mdesc", mdesc),
        _data("pPath", "pointRx", points),
    ]
    dtx = (
        f'<?xml version="1.0" encoding="utf-8"?>\n<Database xmlns="{NS_DATA}" xmlns:xsi="{XSI}">\n  <Datas>\n'
        + "\n".join(datas)
        + "\n  </Datas>\n</Database>\n"
    )
    code = START_CODE.format(name=path.name, n=len(path.points_mm), source=path.source.name, robot=cell.robot,
                             about="".join(f"  // {line}\n" for line in cell_lines(cell)))
    start = (
        f'<?xml version="1.0" encoding="utf-8"?>\n<Programs xmlns="{NS_PROGRAM}" xmlns:xsi="{XSI}">\n'
        '  <Program name="start">\n    <Locals>\n'
        '      <Local name="i" type="num" xsi:type="array" size="1" />\n    </Locals>\n'
        f"    <Code><![CDATA[{code}]]></Code>\n  </Program>\n</Programs>\n"
    )
    stop = (
        f'<?xml version="1.0" encoding="utf-8"?>\n<Programs xmlns="{NS_PROGRAM}" xmlns:xsi="{XSI}">\n'
        '  <Program name="stop">\n    <Code><![CDATA[begin\n  // the application stops: the motion left cancelled\n'
        '  resetMotion()\nend]]></Code>\n  </Program>\n</Programs>\n'
    )
    pjx = (
        f'<?xml version="1.0" encoding="utf-8"?>\n<Project xmlns="{NS_PROJECT}" xmlns:xsi="{XSI}">\n'
        '  <Parameters version="s7.3" stackSize="5000" millimeterUnit="true" />\n'
        '  <Programs>\n    <Program file="start.pgx" />\n    <Program file="stop.pgx" />\n  </Programs>\n'
        f'  <Database>\n    <Data file="{path.name}.dtx" />\n  </Database>\n  <Libraries />\n</Project>\n'
    )
    return {f"{path.name}.pjx": pjx, f"{path.name}.dtx": dtx, "start.pgx": start, "stop.pgx": stop}


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the VAL3 application folder `out` atomically (checked first; never over an input).

    Args:
        path: The path to export.
        out: The application folder (its name is the application's name).
        protect: Inputs that must not be inside `out`.

    Returns:
        The files written.
    """
    return write_application(application_files(path), out, protect)


def write_application(files: dict[str, str], out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write an application's files (name -> text) as the folder `out`: checked with `check_application` first,
    built beside it and swapped into place, never over an input (`protect`); the one writer of VAL3 folders."""
    target = Path(out).resolve()
    for other in protect:
        if Path(other).resolve() == target or Path(other).resolve().is_relative_to(target):
            raise InputError(f"refusing to write {target}: it holds the input {other}; choose another folder")
    if target.exists() and not target.is_dir():
        raise InputError(f"{target} exists and is not a folder; a VAL3 application is a folder")
    check_application(files)
    tmp = temporary_folder(target)
    try:
        for name, text in files.items():
            (tmp / name).write_text(text, encoding="utf-8")
        swap_in_directory(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return [target / name for name in files]
