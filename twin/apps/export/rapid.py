"""ABB RAPID module `NAME.mod`: tool, work object, the points as `robtarget`s and the moves through them.

Structure as the open post-processors write it (RoboDK's `ABB_RAPID_IRC5.py`: `MODULE`, `PERS tooldata`, `PERS
wobjdata`, a `PROC` starting with `ConfJ \\On; ConfL \\Off;`, `MoveJ`/`MoveL ... \\WObj:=`, `ENDPROC`,
`ENDMODULE`). `tIsf` (`tooldata`: flange to tool tip, the tool's mass with its centre of gravity half way down
the tool), `wSheet` (`wobjdata`: the sheet frame in the robot base), `pPath{n}` (`robtarget`, in `wSheet`) and
`vPath{n}` (`speeddata`, TCP speed = the programmed feed [mm/s]); `main` sets `ConfJ \\On; ConfL \\Off;` (the
joint move goes to the written configuration, the linear moves keep it), moves `MoveJ` to the approach point
(`twin.apps.export.motion`), then `MoveL` down onto the path and through it with zone `z0`, and a last `MoveL`
(the retract) to `fine`. Each robtarget's robconf [cf1, cf4, cf6, cfx] is that point's IK solution
(`twin.apps.export.configuration`). Orientations are unit quaternions [q1, q2, q3, q4] = [w, x, y, z].

A program over the RAPID limit (`twin.apps.export.parts`) is written as modules `NAME_1.mod`, ... each with a
procedure `NAME_k` and its own `LOCAL` data, and a main module `NAME.mod` holding the tool and work object and a
`main` that calls `NAME_1;`, `NAME_2;`, ... in order.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path

from twin.apps.export.parts import parts
from twin.apps.export.program import ProgramPath, fmt, quaternion_wxyz
from twin.base.csvio import write_text

QUATERNION_DECIMALS = 6
APPROACH_SPEED = "v100"  # the joint move to the approach point [mm/s of the TCP]


def _vec(values: Iterable[float], decimals: int) -> str:
    return "[" + ",".join(fmt(v, decimals) for v in values) + "]"


def declarations(path: ProgramPath) -> list[str]:
    """The tool and the work object (global: a split program's parts use them too)."""
    cell = path.cell
    half = math.radians(cell.yaw_deg) / 2.0
    q_sheet = _vec((math.cos(half), 0.0, 0.0, math.sin(half)), QUATERNION_DECIMALS)  # the yaw about the base z
    return [
        f"  PERS tooldata tIsf:=[TRUE,[[0,0,{fmt(cell.tool_length_mm)}],[1,0,0,0]],"
        f"[{fmt(cell.tool_mass_kg, 3)},[0,0,{fmt(cell.tool_length_mm / 2)}],[1,0,0,0],0,0,0]];",
        f'  PERS wobjdata wSheet:=[FALSE,TRUE,"",[{_vec(cell.p_base_sheet_mm, 4)},{q_sheet}],'
        "[[0,0,0],[1,0,0,0]]];",
    ]


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


def _motion(path: ProgramPath, proc: str, last: bool, local: str) -> list[str]:
    """The points, speeds and the procedure `proc` that moves through them."""
    first = (
        [f"    MoveJ pPath{{1}},{APPROACH_SPEED},fine,tIsf\\WObj:=wSheet;", "    FOR i FROM 2 TO nPath - 1 DO"]
        if path.joint_start
        else ["    FOR i FROM 1 TO nPath - 1 DO"]
    )
    return [
        *path_data(path, local),
        "",
        f"  PROC {proc}()",
        "    ConfJ \\On;",
        "    ConfL \\Off;",
        *first,
        "      MoveL pPath{i},vPath{i},z0,tIsf\\WObj:=wSheet;",
        "    ENDFOR",
        f"    MoveL pPath{{nPath}},vPath{{nPath}},{'fine' if last else 'z0'},tIsf\\WObj:=wSheet;",
        "  ENDPROC",
    ]


def about(path: ProgramPath) -> list[str]:
    """The header comment: where the program came from, its robot and first configuration."""
    config = path.cell.configuration
    return [
        f"  ! tx200-twin export of {path.source.name}: {len(path.points_mm)} points, sheet frame (work object wSheet)",
        f"  ! robot {path.cell.robot}" + (f", first point {config.describe()}" if config is not None else ""),
    ]


def program_files(path: ProgramPath) -> dict[str, str]:
    """The module `NAME.mod`, and for a split program the parts' modules: file name -> text."""
    pieces = parts(path, "rapid")
    if len(pieces) == 1:
        lines = [f"MODULE {path.name}", *about(path), *declarations(path), *_motion(path, "main", True, ""),
                 "ENDMODULE"]
        return {f"{path.name}.mod": "\n".join(lines) + "\n"}
    main = [
        f"MODULE {path.name}", *about(path), f"  ! {len(pieces)} parts, in order", *declarations(path), "",
        "  PROC main()", *(f"    {p.name};" for p in pieces), "  ENDPROC", "ENDMODULE",
    ]
    files = {f"{path.name}.mod": "\n".join(main) + "\n"}
    for k, piece in enumerate(pieces):
        body = _motion(piece, piece.name, k == len(pieces) - 1, "LOCAL ")
        files[f"{piece.name}.mod"] = "\n".join([f"MODULE {piece.name}", *body, "ENDMODULE"]) + "\n"
    return files


def module_text(path: ProgramPath) -> str:
    """The main module's text."""
    return program_files(path)[f"{path.name}.mod"]


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the module, and any parts beside it, atomically (never over an input)."""
    return [
        write_text(Path(out) if name == f"{path.name}.mod" else Path(out).with_name(name), text, protect=protect)
        for name, text in program_files(path).items()
    ]
