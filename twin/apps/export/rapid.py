"""ABB RAPID module `NAME.mod`: tool, work object, home, the points as `robtarget`s and the moves through them.

Structure as the open post-processors write it (RoboDK's `ABB_RAPID_IRC5.py`: `MODULE`, `PERS tooldata`, `PERS
wobjdata`, a `PROC` starting with `ConfJ \\On; ConfL \\Off;`, `MoveJ`/`MoveL ... \\WObj:=`, `ENDPROC`,
`ENDMODULE`). `tIsf` (`tooldata`: flange to tool tip, the tool's mass with its centre of gravity
`CellSetup.tool_cog_mm`, half way down the tool, its inertia ix iy iz `CellSetup.tool_inertia_kgm2`), `wSheet` (`wobjdata`: the sheet frame in the robot base), `jHome`
(`jointtarget`: the robot's home keyframe in controller axis values, `program.home_axes_deg`, degrees; external
axes 9E9), `zPath` (`zonedata`, `zone_mm`), `pPath{n}` (`robtarget`, in `wSheet`) and `vPath{n}` (`speeddata`,
TCP speed = the programmed feed [mm/s]). `isf_NAME` (below) sets `ConfJ \\On; ConfL \\Off;` (the joint move goes to the
written configuration, the linear moves keep it), moves `MoveAbsJ jHome` (HOME), `MoveJ` to the approach point
(`twin.apps.export.motion`), then `MoveL` down onto the path and through it, the retract, and `MoveAbsJ jHome`
again: HOME is the first and the last move.

Zones: a point where the path turns by more than `motion.CORNER_DEG` (`motion.corners`: the bottom of the move
down onto the path, the top of the path's last move, a groove's reversals) and the retract are reached `fine`, the
robot at rest on them as the path asks; the others with `zPath`, whose radius is chosen from the chord tolerance
`motion.CHORD_TOL_MM`: a corner path of radius r across a turn θ passes the point at r·sin(θ/2)/2 (the middle of
the parabola between the two points at distance r from it), so r = 2·tol / sin(θ/2) for the largest turn among the
blended points, at most `ZONE_MAX_MM` (ABB's z1; the controller itself halves a zone longer than half a move). The
blended moves run in `FOR` loops; a `fine` point is its own `MoveL`. Each robtarget's robconf [cf1, cf4, cf6, cfx]
is that point's IK solution (`twin.apps.export.configuration`). Orientations are unit quaternions [q1, q2, q3, q4]
= [w, x, y, z]. Checked against public RAPID (read, not copied): `CONST zonedata zPrecisa := [FALSE,0.3,0.3,0.3,
0.03,0.3,0.03]` (z0's values) and `CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]];` with
`MoveAbsJ jHome,v200,fine,tool0;` in RAPID examples on GitHub.

Names: the module `NAME` (file `NAME.mod`, named as the program whatever `--out`'s extension) holds the
procedure `isf_NAME`, not `main`: a module and a routine may not share a name in RAPID, and the task already has
a main module with its own `main` (RoboDK's ABB post avoids the clash the same way, with `MOD_<prog>`). Call
`isf_NAME;` from the task's `main`, or load the program file `NAME.pgf` (RobotStudio's `<Program><Module>` list
of the modules) and set the task's Main entry (Controller > Task) to `isf_NAME`; the header says so. Not checked
on a controller: loading the `.pgf` as it is written here.

A program over the RAPID limit (`twin.apps.export.parts`) is written as modules `NAME_1.mod`, ... each with a
procedure `isf_NAME_k` and its own `LOCAL` data, and a main module `NAME.mod` holding the tool, the work object,
the home and the zone and `isf_NAME`, which moves HOME, calls `isf_NAME_1;`, `isf_NAME_2;`, ... in order and moves
HOME again.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from twin.apps.export.motion import CHORD_TOL_MM, corners, turn_angles_deg
from twin.apps.export.parts import parts
from twin.apps.export.program import ProgramPath, cell_lines, fmt, home_axes_deg, quaternion_wxyz
from twin.base.csvio import write_text

QUATERNION_DECIMALS = 6
APPROACH_SPEED = "v100"  # the joint moves HOME and to the approach point [mm/s of the TCP]
#: The largest zone of the blended moves [mm]: ABB's z1 (module docstring).
ZONE_MAX_MM = 1.0
#: The zone of the blended moves and HOME's jointtarget.
ZONE = "zPath"
HOME = "jHome"
#: The procedures' prefix: `isf_NAME` in module `NAME` (module docstring).
ENTRY_PREFIX = "isf_"


def _vec(values: Iterable[float], decimals: int) -> str:
    return "[" + ",".join(fmt(v, decimals) for v in values) + "]"


def declarations(path: ProgramPath) -> list[str]:
    """The tool, the work object and the home (global: a split program's parts use them too)."""
    cell = path.cell
    half = math.radians(cell.yaw_deg) / 2.0
    q_sheet = _vec((math.cos(half), 0.0, 0.0, math.sin(half)), QUATERNION_DECIMALS)  # the yaw about the base z
    return [
        f"  PERS tooldata tIsf:=[TRUE,[[0,0,{fmt(cell.tool_length_mm)}],[1,0,0,0]],"
        f"[{fmt(cell.tool_mass_kg, 3)},{_vec(cell.tool_cog_mm, 4)},[1,0,0,0],"
        f"{_vec(cell.tool_inertia_kgm2, 6)[1:-1]}]];",
        f'  PERS wobjdata wSheet:=[FALSE,TRUE,"",[{_vec(cell.p_base_sheet_mm, 4)},{q_sheet}],'
        "[[0,0,0],[1,0,0,0]]];",
        f"  CONST jointtarget {HOME}:=[{_vec(home_axes_deg(cell), 4)},[9E9,9E9,9E9,9E9,9E9,9E9]];",
    ]


def home_move() -> str:
    """The joint move HOME (`jHome`), at rest."""
    return f"    MoveAbsJ {HOME},{APPROACH_SPEED},fine,tIsf;"


def zone_mm(path: ProgramPath) -> float:
    """The radius of `zPath` [mm]: the largest whose corner path keeps every blended point within the chord
    tolerance (module docstring)."""
    points = path.points_mm
    blended = ~corners(points)
    blended[:2] = False  # the approach (MoveJ, fine) and the first move's own start
    turn = float(np.max(turn_angles_deg(points)[blended], initial=0.0))
    sine = math.sin(math.radians(turn) / 2.0)
    return ZONE_MAX_MM if sine <= 0.0 else min(ZONE_MAX_MM, 2.0 * CHORD_TOL_MM / sine)


def zone_declaration(path: ProgramPath) -> str:
    """`zPath` as z-zones are written: pzone_tcp = pzone_ori = pzone_eax = zone_leax = r [mm], zone_ori = zone_reax
    = r / 10 [deg]."""
    r = zone_mm(path)
    return f"  CONST zonedata {ZONE}:=[FALSE,{fmt(r)},{fmt(r)},{fmt(r)},{fmt(r / 10)},{fmt(r)},{fmt(r / 10)}];"


def robtargets(path: ProgramPath) -> list[str]:
    """Each point's `robtarget`: position [mm] in `wSheet`, the tool's orientation, the point's robconf."""
    q = _vec(quaternion_wxyz(path.cell.R_sheet_tool), QUATERNION_DECIMALS)
    confs = [list(c.rapid) for c in path.configurations] or [[0, 0, 0, 0]] * len(path.points_mm)
    return [
        f"[{_vec(p, 4)},{q},[{','.join(map(str, conf))}],[9E9,9E9,9E9,9E9,9E9,9E9]]"
        for p, conf in zip(path.points_mm, confs, strict=True)
    ]


def speeddata(feed_mm_s: float) -> str:
    """The `speeddata` of a move at `feed_mm_s` [mm/s of the TCP]."""
    return f"[{fmt(feed_mm_s, 3)},500,5000,1000]"


def path_data(path: ProgramPath, local: str) -> list[str]:
    """`nPath`, the points `pPath{n}` and the feeds into them `vPath{n}` (`local`: "" or "LOCAL ")."""
    n = len(path.points_mm)
    points = ",\n    ".join(robtargets(path))
    speeds = ",\n    ".join(speeddata(v) for v in path.feed_mm_s)
    return [
        f"  {local}CONST num nPath:={n};",
        f"  {local}CONST robtarget pPath{{{n}}}:=[\n    {points}];",
        f"  {local}CONST speeddata vPath{{{n}}}:=[\n    {speeds}];",
    ]


def moves(first: int, count: int, stop: np.ndarray, move: str = "MoveL ", zone: str = ZONE) -> list[str]:
    """The linear moves (`move`, e.g. "MoveL " or "EGMMoveL egmID,") to points `first`..`count - 1` (0-based, of
    one procedure): a point the robot stops on is its own move to `fine`, the others run in `FOR` loops with
    `zone`."""
    lines: list[str] = []
    j = first
    while j < count:
        if stop[j]:
            lines.append(f"    {move}pPath{{{j + 1}}},vPath{{{j + 1}}},fine,tIsf\\WObj:=wSheet;")
            j += 1
            continue
        end = j
        while end + 1 < count and not stop[end + 1]:
            end += 1
        if end == j:
            lines.append(f"    {move}pPath{{{j + 1}}},vPath{{{j + 1}}},{zone},tIsf\\WObj:=wSheet;")
        else:
            lines += [f"    FOR i FROM {j + 1} TO {end + 1} DO",
                      f"      {move}pPath{{i}},vPath{{i}},{zone},tIsf\\WObj:=wSheet;", "    ENDFOR"]
        j = end + 1
    return lines


def _motion(path: ProgramPath, proc: str, stop: np.ndarray, local: str, home: bool) -> list[str]:
    """The points, speeds and the procedure `proc` that moves through them (`stop`: per point, reached `fine`);
    `home`: it starts and ends with the move HOME."""
    first = [f"    MoveJ pPath{{1}},{APPROACH_SPEED},fine,tIsf\\WObj:=wSheet;"] if path.joint_start else []
    return [
        *path_data(path, local),
        "",
        f"  PROC {proc}()",
        "    ConfJ \\On;",
        "    ConfL \\Off;",
        *([home_move()] if home else []),
        *first,
        *moves(1 if path.joint_start else 0, len(path.points_mm), stop),
        *([home_move()] if home else []),
        "  ENDPROC",
    ]


def about(path: ProgramPath) -> list[str]:
    """The header comment: where the program came from, its robot and first configuration."""
    config = path.cell.configuration
    return [
        f"  ! tx200-twin export of {path.source.name}: {len(path.points_mm)} points, sheet frame (work object wSheet)",
        f"  ! robot {path.cell.robot}" + (f", first point {config.describe()}" if config is not None else ""),
        *(f"  ! {line}" for line in cell_lines(path.cell)),
    ]


def entry(name: str) -> str:
    """The procedure of module `name` (`isf_NAME`): never the module's own name, never a task's `main`."""
    return f"{ENTRY_PREFIX}{name}"


def how_to_call(path: ProgramPath) -> list[str]:
    """The header lines that say how the program is started (module docstring)."""
    return [f"  ! entry: {entry(path.name)} (no main: call {entry(path.name)}; from the task's main, or load "
            f"{path.name}.pgf and set the task's Main entry to {entry(path.name)})"]


def program_file(modules: Iterable[str]) -> str:
    """The program file `NAME.pgf` listing the modules (RobotStudio's `<Program><Module>` layout)."""
    listed = "".join(f"\t<Module>{name}</Module>\n" for name in modules)
    return f'<?xml version="1.0" encoding="ISO-8859-1" ?>\n<Program>\n{listed}</Program>\n'


def with_program_file(path: ProgramPath, files: dict[str, str]) -> dict[str, str]:
    """`files` with `NAME.pgf` listing its modules."""
    return {**files, f"{path.name}.pgf": program_file(name for name in files if name.endswith(".mod"))}


def program_files(path: ProgramPath) -> dict[str, str]:
    """The module `NAME.mod`, for a split program the parts' modules, and `NAME.pgf`: file name -> text."""
    pieces = parts(path, "rapid")
    stop = corners(path.points_mm)
    data = [*declarations(path), zone_declaration(path)]
    if len(pieces) == 1:
        lines = [f"MODULE {path.name}", *about(path), *how_to_call(path), *data,
                 *_motion(path, entry(path.name), stop, "", home=True), "ENDMODULE"]
        return with_program_file(path, {f"{path.name}.mod": "\n".join(lines) + "\n"})
    main = [
        f"MODULE {path.name}", *about(path), *how_to_call(path), f"  ! {len(pieces)} parts, in order", *data, "",
        f"  PROC {entry(path.name)}()", "    ConfJ \\On;", "    ConfL \\Off;", home_move(),
        *(f"    {entry(p.name)};" for p in pieces), home_move(), "  ENDPROC", "ENDMODULE",
    ]
    files = {f"{path.name}.mod": "\n".join(main) + "\n"}
    start = 0
    for piece in pieces:
        n = len(piece.points_mm)
        body = _motion(piece, entry(piece.name), stop[start:start + n], "LOCAL ", home=False)
        files[f"{piece.name}.mod"] = "\n".join([f"MODULE {piece.name}", *body, "ENDMODULE"]) + "\n"
        start += n
    return with_program_file(path, files)


def module_text(path: ProgramPath) -> str:
    """The main module's text."""
    return program_files(path)[f"{path.name}.mod"]


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the module `NAME.mod` (in `out`'s folder, named as the program: `--out ISF` and `--out ISF.mod` both
    write `ISF.mod`), any parts and `NAME.pgf` beside it, atomically (never over an input)."""
    return [write_text(Path(out).with_name(name), text, protect=protect) for name, text in program_files(path).items()]
