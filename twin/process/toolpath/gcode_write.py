"""G-code export of a tool path: G1 moves in millimetres with the feeds of its sample times
(`twin.process.toolpath.gcode` reads them back)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.base.csvio import write_text
from twin.process.toolpath.groove import ToolPath


def write_gcode(path: ToolPath, file: str | Path, *, comment: str = "tx200-twin tool path") -> Path:
    """Write a path as G1 moves in millimetres (G21 G90), feeds from the path's sample times (atomic).

    Args:
        path: The tool-tip path, sheet frame.
        file: Output file (never an input: the caller chooses a new name).
        comment: Text of the header comment.
    """
    p_mm = path.p_sheet_m * 1e3
    steps = np.linalg.norm(np.diff(p_mm, axis=0), axis=1)
    dt = np.diff(path.t_s)
    feed = np.where(dt > 0, steps / np.where(dt > 0, dt, 1.0) * 60.0, 0.0)
    lines = [f"({comment.replace('(', '[').replace(')', ']')})", "G21 G90 G17",
             f"G0 X{p_mm[0, 0]:.4f} Y{p_mm[0, 1]:.4f} Z{p_mm[0, 2]:.4f}"]
    last_f = None
    for (x, y, z), f in zip(p_mm[1:], feed, strict=True):
        f_txt = f"{f:.2f}"
        word = f" F{f_txt}" if f_txt != last_f and f > 0 else ""
        last_f = f_txt if word else last_f
        lines.append(f"G1 X{x:.4f} Y{y:.4f} Z{z:.4f}{word}")
    lines.append("M30")
    return write_text(file, "\n".join(lines) + "\n")
