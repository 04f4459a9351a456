"""A plain point list: `x_mm, y_mm, z_mm, rx_deg, ry_deg, rz_deg, feed_mm_s` in the sheet frame.

Orientation in the Stäubli convention (R = Rx Ry Rz); the header comment names the frame and the tool.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from twin.apps.export.program import POSITION_DECIMALS, ProgramPath, euler_xyz_deg, fmt
from twin.base.csvio import write_table


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the point list atomically (never over an input)."""
    n = len(path.points_mm)
    r = np.tile(euler_xyz_deg(path.cell.R_sheet_tool), (n, 1))
    origin = " ".join(fmt(v) for v in path.cell.p_base_sheet_mm)
    columns = {
        "x_mm": path.points_mm[:, 0],
        "y_mm": path.points_mm[:, 1],
        "z_mm": path.points_mm[:, 2],
        "rx_deg": r[:, 0],
        "ry_deg": r[:, 1],
        "rz_deg": r[:, 2],
        "feed_mm_s": path.feed_mm_s,
    }
    position = f".{POSITION_DECIMALS}f"
    formats = {"x_mm": position, "y_mm": position, "z_mm": position, "feed_mm_s": ".3f"}
    comment = (
        f"tx200-twin export of {path.source.name}: sheet frame, origin in the robot base {origin} mm, "
        f"yaw {fmt(path.cell.yaw_deg, 3)} deg about the base z; "
        f"tool length {fmt(path.cell.tool_length_mm)} mm"
    )
    return [
        write_table(
            Path(out),
            columns,
            formats=formats | {"rx_deg": ".4f", "ry_deg": ".4f", "rz_deg": ".4f"},
            protect=protect,
            comment=comment,
        )
    ]
