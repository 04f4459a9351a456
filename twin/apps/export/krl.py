"""KUKA KRL program: `NAME.src` (the motion) and `NAME.dat` (its data list: tool, base, points, feeds).

Structure as KUKA's templates and the open post-processors write it (RoboDK's `KUKA_KRC4.py`, the `;FOLD INI`
with `BAS(#INITMOV,0)`; `$VEL.CP`, `$ACC.CP`, `$APO.CDIS` as system variables): `&ACCESS`/`&REL` header, `DEF
NAME( )`, the INI fold, then the motion. The `.dat` declares the tool `T_ISF` (flange to tool tip) and the base
`B_SHEET` (sheet frame in the robot base) as `FRAME`s, the points `P_PATH[n]` as `POS` in the sheet frame, and
the feeds `V_PATH[n]` [m/s]. The first point is the approach point (`twin.apps.export.motion`): it carries the
arm configuration of the robot's IK solution as Status and Turn (`{X ..,Y ..,Z ..,A ..,B ..,C ..,S 'B010',T
'B000001'}`, `twin.apps.export.configuration`), which the `PTP` to it reads (at `PTP_VEL_PERCENT`); the `LIN`s
keep that configuration: down onto the path, through it with `C_DIS` blending, and the last (the retract)
exact, setting `$VEL.CP` (KRL's path speed, m/s) before each move.

A program over the KRL limit (`twin.apps.export.parts`) is written as parts `NAME_1.src/.dat`, ... (each with
its own data list, tool and base) and a main `NAME.src/.dat` whose INI fold is followed by the calls
`NAME_1( )`, `NAME_2( )`, ... in order. Angles A, B, C: R = Rz(A) Ry(B) Rx(C) [deg].
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path

from twin.apps.export.parts import parts
from twin.apps.export.program import ProgramPath, euler_zyx_deg, fmt
from twin.base.csvio import write_text

APPROXIMATION_MM = 0.1  # $APO.CDIS: blend distance, below the 0.5 mm point spacing
#: $ACC.CP [m/s²]: the process feed (33 mm/s) is reached within 33 ms, over 0.6 mm, about one point spacing.
ACC_CP_M_S2 = 1.0
PTP_VEL_PERCENT = 10  # the joint move to the approach point, as VAL3's mApproach
HEADER = ["&ACCESS RVP", "&REL 1"]
INI = [";FOLD INI", "  BAS(#INITMOV,0)", ";ENDFOLD (INI)"]


def _frame(xyz: Iterable[float], abc: Iterable[float], extra: str = "") -> str:
    values = [*xyz, *abc]
    body = ",".join(f"{k} {fmt(v)}" for k, v in zip("XYZABC", values, strict=True))
    return "{" + body + (f",{extra}" if extra else "") + "}"


def _part(path: ProgramPath, last: bool, ini: bool) -> dict[str, str]:
    """One `.src`/`.dat` pair: its points from the first (a PTP when `path.joint_start`) to the last."""
    name, cell, n = path.name.upper(), path.cell, len(path.points_mm)
    abc = euler_zyx_deg(cell.R_sheet_tool)
    config = cell.configuration if path.joint_start else None
    status = config.krl if config is not None else ""  # S and T on the first point: the PTP reads them
    about = f"; robot {cell.robot}" + (f", first point {config.describe()}" if config is not None else "")
    dat = [
        *HEADER,
        f"DEFDAT {name} PUBLIC",
        f"; tx200-twin export of {path.source.name}: {n} points, sheet frame",
        about,
        f"DECL FRAME T_ISF={_frame((0.0, 0.0, cell.tool_length_mm), (0.0, 0.0, 0.0))}",
        f"DECL FRAME B_SHEET={_frame(cell.p_base_sheet_mm, (cell.yaw_deg, 0.0, 0.0))}",  # A: about the base z
        f"DECL INT N_PATH={n}",
        f"DECL POS P_PATH[{n}]",
        *(f"P_PATH[{i}]={_frame(p, abc, status if i == 1 else '')}" for i, p in enumerate(path.points_mm, start=1)),
        f"DECL REAL V_PATH[{n}]",
        *(f"V_PATH[{i}]={fmt(v * 1e-3, 7)}" for i, v in enumerate(path.feed_mm_s, start=1)),
        "ENDDAT",
    ]
    first = (
        [f"BAS(#VEL_PTP,{PTP_VEL_PERCENT})", "PTP P_PATH[1]", "FOR I=2 TO N_PATH-1"]
        if path.joint_start
        else ["FOR I=1 TO N_PATH-1"]
    )
    src = [
        *HEADER,
        f"DEF {name}( )",
        "DECL INT I",
        *(INI if ini else []),
        "; tool: flange -> tool tip; base: robot base -> sheet frame (data list)",
        "$TOOL=T_ISF",
        "$BASE=B_SHEET",
        "$ADVANCE=3",
        f"$ACC.CP={fmt(ACC_CP_M_S2, 3)}",
        f"$APO.CDIS={fmt(APPROXIMATION_MM, 3)}",
        *first,
        "  $VEL.CP=V_PATH[I]",
        "  LIN P_PATH[I] C_DIS",
        "ENDFOR",
        "$VEL.CP=V_PATH[N_PATH]",
        "LIN P_PATH[N_PATH]" + ("" if last else " C_DIS"),
        "END",
    ]
    return {f"{path.name}.src": "\n".join(src) + "\n", f"{path.name}.dat": "\n".join(dat) + "\n"}


def program_files(path: ProgramPath) -> dict[str, str]:
    """The files: `NAME.src` and `NAME.dat`, and for a split program the parts' -> text."""
    pieces = parts(path, "krl")
    if len(pieces) == 1:
        return _part(path, last=True, ini=True)
    name = path.name.upper()
    files = {
        f"{path.name}.src": "\n".join(
            [*HEADER, f"DEF {name}( )", *INI, f"; {len(pieces)} parts of {path.source.name}, in order",
             *(f"{p.name.upper()}( )" for p in pieces), "END"]
        ) + "\n",
        f"{path.name}.dat": "\n".join([*HEADER, f"DEFDAT {name} PUBLIC", "ENDDAT"]) + "\n",
    }
    for k, piece in enumerate(pieces):
        files |= _part(piece, last=k == len(pieces) - 1, ini=False)
    return files


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write `out` with suffix `.src` and its `.dat` beside it, and any parts (each atomically; never over an
    input)."""
    written = []
    for name, text in program_files(path).items():
        target = Path(out).with_name(name)
        written.append(write_text(target, text, protect=protect))
    return written
