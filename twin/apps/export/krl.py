"""KUKA KRL program (KSS 8.x, KR C4): `NAME.src` (the motion) and `NAME.dat` (its data list: home, points, feeds).

What a KUKA programmer loads and runs unchanged:

- **Tool, load and base in slots the user names, never the cell's calibrated 1.** The `.src` assigns the cell's
  tool to `TOOL_DATA[t]`, its mass and centre of gravity to `LOAD_DATA[t]` (`{M ..,CM {X ..,Y ..,Z ..,A 0,B 0,C 0},
  J {X ..,Y ..,Z ..}}`, the layout of the controller's `$config.dat`) and the sheet frame to `BASE_DATA[b]`, then
  activates them as KSS's own code does, `$TOOL=TOOL_DATA[t]`, `$LOAD=LOAD_DATA[t]`, `$BASE=BASE_DATA[b]`, before
  the first motion; a header comment says which slots it overwrites and where the values came from (robot, tool
  length, mass). `t` and `b` are `export --tool-number` (1..16, KRL's `TOOL_DATA[16]`) and `--base-number`
  (1..32, `BASE_DATA[32]`), by default `program.DEFAULT_TOOL_NUMBER` = 16 and `DEFAULT_BASE_NUMBER` = 16: a cell's
  calibrated tool 1, load 1 and base 1 are left as they are (a program that overwrote them would un-calibrate the
  cell for every other program); slot 16 is overwritten, so pick a free one on a cell that uses it. The centre of
  gravity is `CellSetup.tool_cog_mm` (the rule RAPID's `tooldata` uses); the inertia J is
  `CellSetup.tool_inertia_kgm2` [kg m²], a solid cylinder of the tool's length, as the twin's model carries it.
- **The stop-message interrupt.** The INI fold declares and switches on KUKA's stop-message interrupt before
  `BAS(#INITMOV,0)`, as KUKA's program template (`vorgabe`) and the public RSI programs do:
  `GLOBAL INTERRUPT DECL 3 WHEN $STOPMESS==TRUE DO IR_STOPM ( )`, `INTERRUPT ON 3` (ros-industrial
  `kuka_experimental`, `kuka_rsi_hw_interface/krl/KR_C4/ros_rsi.src` and `KR_C4_RSI_4+/ros_rsi.src`, read):
  a stop message (an emergency stop, a drive fault) runs the system's `IR_STOPM`, which stops the robot on its path.
- **HOME.** The first and the last motion are `PTP XHOME_ISF` to the robot's home keyframe in controller axis
  values (`program.home_axes_deg`), an `E6AXIS` of the data list (`{A1 ..,...,A6 ..,E1 0,...,E6 0}`, the layout
  of `XHOME` in `$config.dat`; the cell has no external axes). It has its own name, so the controller's global
  `XHOME` is neither shadowed nor used: the home the twin plans from is the one the program goes to. The first
  PTP to axis values is also the block-coincidence (BCO) run KSS wants before Cartesian moves.
- **The path as spline blocks.** `PTP P_PATH[1]` to the approach point (it carries the arm configuration as Status
  and Turn, `{X ..,Y ..,Z ..,A ..,B ..,C ..,S 'B010',T 'B000001'}`, `twin.apps.export.configuration`, which a PTP
  reads), then the points as `SPLINE ... ENDSPLINE` blocks of `SPL P_PATH[i]` segments, `$VEL.CP` the process feed
  [m/s] (`V_PROC`). A straight stretch between two corners (the move down onto the path, the move up from it) is a
  single `SLIN`. Why spline blocks: the old program sent one `LIN ... C_DIS` block per point, 11 523 on a 60 mm
  cone in 129 s of path, about 90 motion blocks a second (the user's report: ~70), and a KR C4's advance run
  ($ADVANCE) plans a few motion statements ahead: short blocks starve it and the robot slows or stops between them. A SPLINE block is planned as one motion (KSS plans the
  whole block before it moves into it), so the advance run sees one statement per block, not per point; at
  `SPLINE_SEGMENTS` points per block the cone of the user's report is about 0.5 statements a second (the test bound is
  `tests/test_program_structure.py`'s 20 blocks/s).
- **Why SPL, not SLIN, inside a block.** A spline block follows its geometry exactly, at any velocity or override:
  two `SLIN` segments meeting at an angle make a corner the robot can only pass at rest, and a 0.5 mm polyline
  turns at every point (1° on the cone). `SPL` segments pass through every point on a smooth curve; between points
  it leaves the chords by about h²/(8 R) (0.001 mm for 0.37 mm steps on the cone's 15 mm radius), far below the
  0.02 mm the tracker resolves. At a real corner (`motion.corners`: a turn over `motion.CORNER_DEG`, e.g. the
  groove's reversals) the block ends and the robot stops on the point, as the path asks; elsewhere a block ends
  `ENDSPLINE C_SPL` and blends into the next within `$APO.CDIS` (`APPROXIMATION_MM`).
- **Block size.** A block holds at most `SPLINE_SEGMENTS` segments (the points of a run between corners shared
  evenly among its blocks): KSS plans a block as a whole before entering it, so an unbounded block (11 000 points)
  would make the robot wait at its start for the planning, and the next block must be planned while the current
  one runs for `C_SPL` to blend into it. 200 segments at 0.5 mm are 3 s of path: a short plan, rare boundaries.
- **Feeds.** `$VEL.CP=V_PROC` before the path; a segment whose programmed feed (`V_PATH[i]`, the path's own or the
  process feed for a move the path had faster, `twin.apps.export.motion`) differs from the process feed by more
  than `FEED_MATCH` carries `WITH $VEL.CP=V_PATH[i]`. The path's time stamps are rounded, which moves its feeds by
  ~0.1 %; those moves run at the process feed, the others keep theirs.

`$ACC.CP` (`ACC_CP_M_S2`), `$APO.CDIS` and `$ADVANCE=3` are set as before, the `;FOLD INI` with the interrupt
and `BAS(#INITMOV,0)` first (KUKA's templates, RoboDK's `KUKA_KRC4.py`). A program over the KRL limit (`twin.apps.export.parts`) is
written as parts `NAME_1.src/.dat`, ... holding only their points, feeds and motion, and a main `NAME.src/.dat`
that declares the interrupt, sets tool, load and base, moves HOME, calls `NAME_1( )`, `NAME_2( )`, ... in order and moves HOME again; a
part that does not end on a corner blends into the next (`ENDSPLINE C_SPL`). Angles A, B, C: R = Rz(A) Ry(B)
Rx(C) [deg].

Syntax checked against public KRL (read, not copied): Visual Components' KUKA KRL post-processor for VC 4.x
(v1.13): `TOOL_DATA[n]={X ..,...}` and `BASE_DATA[n]={...}` assigned at the start of the main routine,
`$TOOL=TOOL_DATA[n]`, `$BASE=BASE_DATA[n]`, `$LOAD=LOAD_DATA[n]`, `SLIN ... WITH $VEL.CP=.. ... C_SPL`;
majroy/d3dslic3r's KUKA writer (`BASE_DATA[1] = {...}` in the `.src`, `SPTP XHOME`, `SLIN ... C_Spl`); a public
blade-machining script writing `SPLINE WITH $VEL=...`, `SPL NAME[j]`, `ENDSPLINE` for dense CAM points, and
`$BASE = BASE_DATA[6]`, `$TOOL = TOOL_DATA[2]`; `$config.dat` contents as KUKA backup tools parse them (`LOAD_DATA[n]=
{M ..,CM {X ..,Y ..,Z ..,A ..,B ..,C ..},J {X ..,Y ..,Z ..}}`, `DECL E6AXIS XHOME1=...`). Not found in public code and
taken from KUKA's KSS 8 manual as recalled, to be checked on a controller before a first run: `ENDSPLINE C_SPL`
(a block blended into the next with `$APO.CDIS`); `WITH $VEL.CP=` on an `SPL` segment; that a spline block counts
as one statement for the advance run; that a `SLIN`-`SLIN` bend inside a block is passed at rest.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from itertools import pairwise
from pathlib import Path

import numpy as np

from twin.apps.export.motion import corners
from twin.apps.export.parts import parts
from twin.apps.export.program import ProgramPath, cell_lines, euler_zyx_deg, fmt, home_axes_deg
from twin.base.csvio import write_text

APPROXIMATION_MM = 0.1  # $APO.CDIS: how far a block blends into the next (C_SPL), below the 0.5 mm point spacing
#: $ACC.CP [m/s²]: the process feed (33 mm/s) is reached within 33 ms, over 0.6 mm, about one point spacing.
ACC_CP_M_S2 = 1.0
PTP_VEL_PERCENT = 10  # the joint moves (HOME, the approach point), as VAL3's mApproach
#: The data list's home (an E6AXIS of the robot's home keyframe); not the controller's global XHOME.
HOME = "XHOME_ISF"
#: Segments (points) per SPLINE block at most (module docstring).
SPLINE_SEGMENTS = 200
#: A segment whose feed is within this fraction of the process feed runs at the process feed.
FEED_MATCH = 0.01
HEADER = ["&ACCESS RVP", "&REL 1"]
#: KUKA's stop-message interrupt: its number and declaration, as KUKA's template writes it (module docstring).
STOPMESS_INTERRUPT = 3
INI = [";FOLD INI", f"  GLOBAL INTERRUPT DECL {STOPMESS_INTERRUPT} WHEN $STOPMESS==TRUE DO IR_STOPM ( )",
       f"  INTERRUPT ON {STOPMESS_INTERRUPT}", "  BAS(#INITMOV,0)", ";ENDFOLD (INI)"]


def _frame(xyz: Iterable[float], abc: Iterable[float], extra: str = "") -> str:
    values = [*xyz, *abc]
    body = ",".join(f"{k} {fmt(v)}" for k, v in zip("XYZABC", values, strict=True))
    return "{" + body + (f",{extra}" if extra else "") + "}"


#: An E6AXIS's external axes E1..E6 (KRL's structure: six, whatever the arm).
EXTERNAL_AXES = (1, 2, 3, 4, 5, 6)


def _axes(axes_deg: Iterable[float]) -> str:
    """An E6AXIS literal: A1..A6 and the (absent) external axes E1..E6 at 0."""
    values = [f"A{i} {fmt(v)}" for i, v in enumerate(axes_deg, start=1)] + [f"E{i} 0.0" for i in EXTERNAL_AXES]
    return "{" + ",".join(values) + "}"


def setup(path: ProgramPath) -> list[str]:
    """The lines that set the controller's tool, load and base from the cell and activate them (module docstring),
    then the motion parameters; before any motion."""
    cell = path.cell
    cog, inertia = cell.tool_cog_mm, cell.tool_inertia_kgm2
    load = (f"{{M {fmt(cell.tool_mass_kg, 3)},CM {_frame(cog, (0.0, 0.0, 0.0))},"
            f"J {{X {fmt(inertia[0], 6)},Y {fmt(inertia[1], 6)},Z {fmt(inertia[2], 6)}}}}}")
    tool, base = path.tool_number, path.base_number
    return [
        f"; this program OVERWRITES tool {tool} (TOOL_DATA[{tool}], LOAD_DATA[{tool}]) and base {base} "
        f"(BASE_DATA[{base}]) of the controller (export --tool-number, --base-number); tool 1, load 1 and base 1 "
        "are left as they are",
        f"; their values, from the cell of robot {cell.robot} (tx200-twin):",
        f"; the ISF tool, {fmt(cell.tool_length_mm, 3)} mm flange -> tip along the flange z, "
        f"{fmt(cell.tool_mass_kg, 3)} kg, centre of gravity "
        + (f"{fmt(float(cog[2]), 3)} mm along it (half the tool)" if cell.cog_mm is None else
           f"({', '.join(fmt(float(c), 3) for c in cog)}) mm in the flange frame (declared)"),
        "; base: the sheet frame in the robot base (origin [mm], A = its yaw about the base z [deg])",
        f"TOOL_DATA[{tool}]={_frame((0.0, 0.0, cell.tool_length_mm), (0.0, 0.0, 0.0))}",
        f"LOAD_DATA[{tool}]={load}",
        f"BASE_DATA[{base}]={_frame(cell.p_base_sheet_mm, (cell.yaw_deg, 0.0, 0.0))}",
        f"$TOOL=TOOL_DATA[{tool}]",
        f"$LOAD=LOAD_DATA[{tool}]",
        f"$BASE=BASE_DATA[{base}]",
        "$ADVANCE=3",
        f"$ACC.CP={fmt(ACC_CP_M_S2, 3)}",
        f"$APO.CDIS={fmt(APPROXIMATION_MM, 3)}",
        f"BAS(#VEL_PTP,{PTP_VEL_PERCENT})",
    ]


def _runs(stop: np.ndarray, first: int, count: int) -> list[tuple[int, int, bool]]:
    """The moves to points `first`..`count - 1` (0-based, of one file) in runs: (start, stop, blended).

    A run ends at a corner (`stop`) or the file's last point; a run longer than `SPLINE_SEGMENTS` is shared evenly
    among as few blocks as hold it. `blended`: the run ends on no corner, so its block blends into the next.
    """
    ends = [j for j in range(first, count) if stop[j] or j == count - 1]
    out: list[tuple[int, int, bool]] = []
    start = first
    for end in ends:
        n = end + 1 - start
        blocks = -(-n // SPLINE_SEGMENTS)
        cuts = [start + round(k * n / blocks) for k in range(blocks + 1)]
        out += [(a, b, b < end + 1 or not stop[end]) for a, b in pairwise(cuts)]
        start = end + 1
    return out


def _motion(path: ProgramPath, stop: np.ndarray) -> list[str]:
    """The moves through one file's points: a PTP to the first when `path.joint_start`, then SLIN / SPLINE runs.

    Args:
        path: The file's points and feeds.
        stop: Per point, whether the robot stops on it (`motion.corners` of the whole program, sliced).
    """
    process = path.process_feed
    lines = ["PTP P_PATH[1]"] if path.joint_start else []
    lines.append("$VEL.CP=V_PROC")

    def target(kind: str, j: int) -> str:
        differs = abs(path.feed_mm_s[j] / process - 1.0) > FEED_MATCH
        return f"{kind} P_PATH[{j + 1}]" + (f" WITH $VEL.CP=V_PATH[{j + 1}]" if differs else "")

    for a, b, blended in _runs(stop, 1 if path.joint_start else 0, len(path.points_mm)):
        if b - a == 1:  # a straight move between two corners
            lines.append(target("SLIN", a) + (" C_SPL" if blended else ""))
        else:
            lines += ["SPLINE", *(f"  {target('SPL', j)}" for j in range(a, b)),
                      "ENDSPLINE" + (" C_SPL" if blended else "")]
    return lines


def _data(path: ProgramPath, home: bool) -> list[str]:
    """The data list: the home (`home`), the process feed, the points and their feeds."""
    name, cell, n = path.name.upper(), path.cell, len(path.points_mm)
    abc = euler_zyx_deg(cell.R_sheet_tool)
    config = cell.configuration if path.joint_start else None
    status = config.krl if config is not None else ""  # S and T on the first point: the PTP reads them
    about = f"; robot {cell.robot}" + (f", first point {config.describe()}" if config is not None else "")
    return [
        *HEADER,
        f"DEFDAT {name} PUBLIC",
        f"; tx200-twin export of {path.source.name}: {n} points, sheet frame (base {path.base_number}), tool {path.tool_number}",
        about,
        *(f"; {line}" for line in cell_lines(cell)),
        *([f"DECL E6AXIS {HOME}={_axes(home_axes_deg(cell))}"] if home else []),
        f"DECL REAL V_PROC={fmt(path.process_feed * 1e-3, 7)}",
        f"DECL POS P_PATH[{n}]",
        *(f"P_PATH[{i}]={_frame(p, abc, status if i == 1 else '')}" for i, p in enumerate(path.points_mm, start=1)),
        f"DECL REAL V_PATH[{n}]",
        *(f"V_PATH[{i}]={fmt(v * 1e-3, 7)}" for i, v in enumerate(path.feed_mm_s, start=1)),
        "ENDDAT",
    ]


def _text(lines: list[str]) -> str:
    return "\n".join(lines) + "\n"


def program_files(path: ProgramPath) -> dict[str, str]:
    """The files: `NAME.src` and `NAME.dat`, and for a split program the parts' -> text (main first, then the
    parts in order)."""
    pieces = parts(path, "krl")
    stop = corners(path.points_mm)
    name = path.name.upper()
    if len(pieces) == 1:
        src = [*HEADER, f"DEF {name}( )", *(f"; {line}" for line in cell_lines(path.cell)), *INI, *setup(path), f"PTP {HOME}", *_motion(path, stop), f"PTP {HOME}",
               "END"]
        return {f"{path.name}.src": _text(src), f"{path.name}.dat": _text(_data(path, home=True))}
    main_dat = [*HEADER, f"DEFDAT {name} PUBLIC", f"; {len(pieces)} parts of {path.source.name}, in order",
                f"DECL E6AXIS {HOME}={_axes(home_axes_deg(path.cell))}", "ENDDAT"]
    files = {
        f"{path.name}.src": _text([*HEADER, f"DEF {name}( )", *(f"; {line}" for line in cell_lines(path.cell)), *INI, *setup(path), f"PTP {HOME}",
                                   *(f"{p.name.upper()}( )" for p in pieces), f"PTP {HOME}", "END"]),
        f"{path.name}.dat": _text(main_dat),
    }
    start = 0
    for k, piece in enumerate(pieces, start=1):
        n = len(piece.points_mm)
        about = f"; part {k} of {len(pieces)}: points {start + 1}..{start + n} of the program ({path.name.upper()})"
        src = [*HEADER, f"DEF {piece.name.upper()}( )", about, *_motion(piece, stop[start:start + n]), "END"]
        files[f"{piece.name}.src"] = _text(src)
        files[f"{piece.name}.dat"] = _text(_data(piece, home=False))
        start += n
    return files


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write `out` with suffix `.src` and its `.dat` beside it, and any parts (each atomically; never over an
    input)."""
    written = []
    for name, text in program_files(path).items():
        target = Path(out).with_name(name)
        written.append(write_text(target, text, protect=protect))
    return written
