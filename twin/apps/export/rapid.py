"""ABB RAPID module `NAME.mod`: tool, work object, the points as `robtarget`s and a `MoveL` through them.

`tIsf` (`tooldata`: flange to tool tip, mass), `wSheet` (`wobjdata`: the sheet frame in the robot base),
`pPath{n}` (`robtarget`, in `wSheet`) and `vPath{n}` (`speeddata`, TCP speed = the path's feed [mm/s]);
`main` sets `ConfJ \\On; ConfL \\Off;` (the joint move goes to the written configuration, the linear moves
keep it), moves `MoveJ` to the first point, then `MoveL` through the rest with zone `z0`.
Each robtarget's robconf [cf1, cf4, cf6, cfx] is that point's IK solution (`twin.apps.export.configuration`).
Orientations are unit quaternions [q1, q2, q3, q4] = [w, x, y, z].
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path

from twin.apps.export.program import ProgramPath, fmt, quaternion_wxyz
from twin.base.csvio import write_text

QUATERNION_DECIMALS = 6


def _vec(values: Iterable[float], decimals: int) -> str:
    return "[" + ",".join(fmt(v, decimals) for v in values) + "]"


def module_text(path: ProgramPath) -> str:
    """The module's text."""
    cell, n = path.cell, len(path.points_mm)
    q = _vec(quaternion_wxyz(cell.R_sheet_tool), QUATERNION_DECIMALS)
    half = math.radians(cell.yaw_deg) / 2.0
    q_sheet = _vec((math.cos(half), 0.0, 0.0, math.sin(half)), QUATERNION_DECIMALS)  # the yaw about the base z
    confs = [list(c.rapid) for c in path.configurations] or [[0, 0, 0, 0]] * n
    points = ",\n    ".join(
        f"[{_vec(p, 4)},{q},[{','.join(map(str, conf))}],[9E9,9E9,9E9,9E9,9E9,9E9]]"
        for p, conf in zip(path.points_mm, confs, strict=True)
    )
    config = cell.configuration
    speeds = ",\n    ".join(f"[{fmt(v, 3)},500,5000,1000]" for v in path.feed_mm_s)
    lines = [
        f"MODULE {path.name}",
        f"  ! tx200-twin export of {path.source.name}: {n} points, sheet frame (work object wSheet)",
        f"  ! robot {cell.robot}" + (f", first point {config.describe()}" if config is not None else ""),
        f"  PERS tooldata tIsf:=[TRUE,[[0,0,{fmt(cell.tool_length_mm)}],[1,0,0,0]],"
        f"[{fmt(cell.tool_mass_kg, 3)},[0,0,{fmt(cell.tool_length_mm / 2)}],[1,0,0,0],0,0,0]];",
        f'  PERS wobjdata wSheet:=[FALSE,TRUE,"",[{_vec(cell.p_base_sheet_mm, 4)},{q_sheet}],'
        "[[0,0,0],[1,0,0,0]]];",
        f"  CONST num nPath:={n};",
        f"  CONST robtarget pPath{{{n}}}:=[\n    {points}];",
        f"  CONST speeddata vPath{{{n}}}:=[\n    {speeds}];",
        "",
        "  PROC main()",
        "    ConfJ \\On;",
        "    ConfL \\Off;",
        "    MoveJ pPath{1},v100,fine,tIsf\\WObj:=wSheet;",
        "    FOR i FROM 2 TO nPath DO",
        "      MoveL pPath{i},vPath{i},z0,tIsf\\WObj:=wSheet;",
        "    ENDFOR",
        "  ENDPROC",
        "ENDMODULE",
    ]
    return "\n".join(lines) + "\n"


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the module atomically (never over an input)."""
    return [write_text(Path(out), module_text(path), protect=protect)]
