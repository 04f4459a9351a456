"""G-code for CNC-style controllers and RoboDK: `G1` moves in the sheet frame, feed from the path.

A rapid `G0` to the approach point above the path (`twin.apps.export.motion`), `G1` down onto the path and
through it, and a `G1` retract to the safe height.

The header comments give the tool and the frame: use the sheet frame's origin in the robot base as the
work offset (`G54`), the tool length as the tool offset. Millimetres (`G21`), absolute (`G90`), XY plane
(`G17`); the feed `F` [mm/min] is modal and written only when it changes at the printed precision.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from twin.apps.export.program import ProgramPath, cell_lines, euler_xyz_deg, fmt
from twin.base.csvio import write_text

FEED_DECIMALS = 2


def program_text(path: ProgramPath) -> str:
    """The program's text."""
    cell = path.cell
    origin = " ".join(f"{k}{fmt(v)}" for k, v in zip("XYZ", cell.p_base_sheet_mm, strict=True))
    rx, ry, rz = euler_xyz_deg(cell.R_sheet_tool)
    lines = [
        "%",
        f"(tx200-twin export of {path.source.name}: {len(path.points_mm)} points, sheet frame)",
        *(f"({line.replace('(', '[').replace(')', ']')})" for line in cell_lines(cell)),
        f"(work offset G54 = sheet frame origin in the robot base: {origin} mm)",
        f"(tool: length {fmt(cell.tool_length_mm)} mm along the flange z; "
        f"orientation rx {fmt(rx, 3)} ry {fmt(ry, 3)} rz {fmt(rz, 3)} deg)",
        "G21 G90 G17",
        "G54",
    ]
    if cell.yaw_deg != 0.0:  # the sheet frame turned about the base z: a coordinate rotation about its origin
        lines += [f"(sheet frame yaw {fmt(cell.yaw_deg, 3)} deg about the base z)", f"G68 X0 Y0 R{fmt(cell.yaw_deg, 4)}"]
    last_feed = ""
    for i, (p, v) in enumerate(zip(path.points_mm, path.feed_mm_s, strict=True)):
        if i == 0 and path.approach:
            lines.append(f"G0 X{fmt(p[0])} Y{fmt(p[1])} Z{fmt(p[2])} (approach at the safe height)")
            continue
        feed = fmt(v * 60.0, FEED_DECIMALS)
        move = f"G1 X{fmt(p[0])} Y{fmt(p[1])} Z{fmt(p[2])}"
        lines.append(move + (f" F{feed}" if feed != last_feed else ""))
        last_feed = feed
    lines += [*(["G69"] if cell.yaw_deg != 0.0 else []), "M30", "%"]
    return "\n".join(lines) + "\n"


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the program atomically (never over an input)."""
    return [write_text(Path(out), program_text(path), protect=protect)]
