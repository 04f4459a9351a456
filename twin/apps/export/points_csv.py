"""A plain point list: `x_mm, y_mm, z_mm, rx_deg, ry_deg, rz_deg, feed_mm_s, contact` in the sheet frame.

The first line is the header of column names (no comment line before it: spreadsheet readers take a first line
as the header). Row 1 is the approach point (reach it with a joint move), then the path's points, then the retract
point (`twin.apps.export.motion`); `feed_mm_s` is the programmed feed of the linear move that reaches the point
(row 1: the process feed, for the joint move's own speed see the controller), `contact` 1 for the path's moves
(the forming moves whose feed is limited), 0 for the approach, the move down onto the path and the retract.
Orientation in the Stäubli convention (R = Rx Ry Rz). The frame and the tool go to a sidecar `NAME.frame.json`
beside the list: the source, the sheet frame's origin in the robot base [mm] and yaw [deg], the tool length [mm]
and mass [kg], the robot.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from twin.apps.export.program import POSITION_DECIMALS, ProgramPath, cell_lines, euler_xyz_deg
from twin.base.csvio import write_table
from twin.base.jsonio import write_json


def sidecar(out: Path) -> Path:
    """The frame and tool file beside a point list `NAME.csv`: `NAME.frame.json`."""
    return Path(out).with_name(Path(out).stem + ".frame.json")


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the point list and its sidecar atomically (never over an input)."""
    n = len(path.points_mm)
    r = np.tile(euler_xyz_deg(path.cell.R_sheet_tool), (n, 1))
    contact = np.ones(n, dtype=int)
    if path.approach:
        contact[[0, 1, n - 1]] = 0
    columns = {
        "x_mm": path.points_mm[:, 0],
        "y_mm": path.points_mm[:, 1],
        "z_mm": path.points_mm[:, 2],
        "rx_deg": r[:, 0],
        "ry_deg": r[:, 1],
        "rz_deg": r[:, 2],
        "feed_mm_s": path.feed_mm_s,
        "contact": contact,
    }
    position = f".{POSITION_DECIMALS}f"
    formats = {"x_mm": position, "y_mm": position, "z_mm": position, "feed_mm_s": ".3f"}
    cell = path.cell
    frame = {
        "source": str(path.source),
        "frame": "sheet",
        "sheet_origin_in_base_mm": cell.p_base_sheet_mm.tolist(),
        "sheet_yaw_deg": cell.yaw_deg,
        "tool_length_mm": cell.tool_length_mm,
        "tool_mass_kg": cell.tool_mass_kg,
        "robot": cell.robot,
        "sources": dict(cell.sources or {}),
        "about": cell_lines(cell),
        "rows": "row 1: approach point (joint move); last row: retract point" if path.approach else "path points",
    }
    return [
        write_table(
            Path(out), columns, formats=formats | {"rx_deg": ".4f", "ry_deg": ".4f", "rz_deg": ".4f"}, protect=protect
        ),
        write_json(sidecar(Path(out)), frame, protect=protect),
    ]
