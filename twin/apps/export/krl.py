"""KUKA KRL program: `NAME.src` (the motion) and `NAME.dat` (its data list: tool, base, points, feeds).

The `.dat` declares the tool `T_ISF` (flange to tool tip) and the base `B_SHEET` (sheet frame in the robot
base) as `FRAME`s, the points `P_PATH[n]` as `POS` in the sheet frame, and the feeds `V_PATH[n]` [m/s].
The first point carries the arm configuration of the robot's IK solution as Status and Turn
(`{X ..,Y ..,Z ..,A ..,B ..,C ..,S 'B010',T 'B000001'}`, `twin.apps.export.configuration`): the `PTP` to it
reads them; the `LIN`s keep that configuration. The `.src` sets `$TOOL` and `$BASE`, moves `PTP` to the first
point, then `LIN ... C_DIS` through the rest, setting `$VEL.CP` (KRL's path speed, m/s) before each move.
Angles A, B, C: R = Rz(A) Ry(B) Rx(C) [deg].
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path

from twin.apps.export.program import ProgramPath, euler_zyx_deg, fmt
from twin.base.csvio import write_text

APPROXIMATION_MM = 0.1  # $APO.CDIS: blend distance, below the 0.5 mm point spacing


def _frame(xyz: Iterable[float], abc: Iterable[float], extra: str = "") -> str:
    values = [*xyz, *abc]
    body = ",".join(f"{k} {fmt(v)}" for k, v in zip("XYZABC", values, strict=True))
    return "{" + body + (f",{extra}" if extra else "") + "}"


def program_files(path: ProgramPath) -> dict[str, str]:
    """The two files: `NAME.src` and `NAME.dat` -> text."""
    name, cell, n = path.name.upper(), path.cell, len(path.points_mm)
    abc = euler_zyx_deg(cell.R_sheet_tool)
    config = cell.configuration
    status = config.krl if config is not None else ""  # S and T on the first point: the PTP reads them
    about = f"; robot {cell.robot}" + (f", first point {config.describe()}" if config is not None else "")
    dat = [
        "&ACCESS RVP",
        "&REL 1",
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
    src = [
        "&ACCESS RVP",
        "&REL 1",
        f"DEF {name}( )",
        "DECL INT I",
        "; tool: flange -> tool tip; base: robot base -> sheet frame (data list)",
        "$TOOL=T_ISF",
        "$BASE=B_SHEET",
        "$ADVANCE=3",
        f"$APO.CDIS={fmt(APPROXIMATION_MM, 3)}",
        "PTP P_PATH[1]",
        "FOR I=2 TO N_PATH",
        "  $VEL.CP=V_PATH[I]",
        "  LIN P_PATH[I] C_DIS",
        "ENDFOR",
        "END",
    ]
    return {f"{path.name}.src": "\n".join(src) + "\n", f"{path.name}.dat": "\n".join(dat) + "\n"}


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write `out` with suffix `.src` and its `.dat` beside it (each atomically; never over an input)."""
    written = []
    for name, text in program_files(path).items():
        target = Path(out).with_name(name)
        written.append(write_text(target, text, protect=protect))
    return written
