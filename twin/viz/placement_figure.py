"""Figure of a placement search (`twin.analysis.placement_search`): the screened error over the workspace.

Left: the base frame's x-y plane, binned; each cell coloured by the least screened rms error of the candidates in
it (the best yaw and z of that cell), infeasible candidates as grey crosses. Right: the screened rms error of
every feasible candidate against its yaw, and the confirmed ones' simulated error. Both mark the default
placement (star) and the best confirmed one (circle).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from twin.analysis.placement_search import PlacementSearch
from twin.viz.style import M_TO_MM, save_figure

#: Cells of the x-y map along each axis.
MAP_CELLS = 14


def _cell_minimum(x: np.ndarray, y: np.ndarray, v: np.ndarray, x_edges: np.ndarray,
                  y_edges: np.ndarray) -> np.ndarray:
    """Least value of `v` per (y, x) cell; NaN where a cell holds none."""
    grid = np.full((len(y_edges) - 1, len(x_edges) - 1), math.nan)
    ix = np.clip(np.searchsorted(x_edges, x, side="right") - 1, 0, len(x_edges) - 2)
    iy = np.clip(np.searchsorted(y_edges, y, side="right") - 1, 0, len(y_edges) - 2)
    for i, j, value in zip(iy, ix, v, strict=True):
        if not value >= grid[i, j]:  # NaN (empty) or larger
            grid[i, j] = value
    return grid


def placement_figure(result: PlacementSearch, path: str | Path, title: str = "") -> Path:
    """Write the figure of `result` (module docstring) as PNG to `path`; returns the path."""
    rows, screened = result.rows, result.screened
    ok = screened[:, 2] == 0
    x, y = rows[:, 0] * M_TO_MM, rows[:, 1] * M_TO_MM
    rms_mm = screened[:, 0] * M_TO_MM
    fig = Figure(figsize=(12.0, 5.0), layout="constrained")
    left, right = fig.subplots(1, 2, width_ratios=(1.2, 1.0))
    x_edges = np.linspace(x.min(), x.max(), MAP_CELLS + 1)
    y_edges = np.linspace(y.min(), y.max(), MAP_CELLS + 1)
    grid = _cell_minimum(x[ok], y[ok], rms_mm[ok], x_edges, y_edges)
    mesh = left.pcolormesh(x_edges, y_edges, np.ma.masked_invalid(grid), cmap="viridis", shading="flat")
    fig.colorbar(mesh, ax=left, label="screened rms error, best yaw and z per cell [mm]")
    if np.any(~ok):
        left.scatter(x[~ok], y[~ok], marker="x", s=12, color="0.5", label=f"infeasible ({int(np.sum(~ok))})")
    best = result.best
    d = result.default_row
    left.scatter([d[0] * M_TO_MM], [d[1] * M_TO_MM], marker="*", s=220, color="white", edgecolors="black",
                 label="default placement", zorder=3)
    if best is not None:
        left.scatter([x[best]], [y[best]], marker="o", s=120, facecolors="none", edgecolors="red", linewidths=2,
                     label=f"best (yaw {math.degrees(rows[best, 3]):.0f}°)", zorder=3)
    left.set_xlabel("sheet origin x, base frame [mm]")
    left.set_ylabel("sheet origin y, base frame [mm]")
    left.set_aspect("equal", adjustable="box")
    left.legend(fontsize=8, loc="upper right")
    yaw_deg = np.degrees(rows[:, 3])
    right.scatter(yaw_deg[ok], rms_mm[ok], s=6, alpha=0.5, label="screened (all feasible)")
    sim_ok = result.confirmed[:, 2] == 0
    chosen = result.confirmed_index[sim_ok]
    right.scatter(yaw_deg[chosen], result.confirmed[sim_ok, 0] * M_TO_MM, marker="D", s=30, color="tab:red",
                  label="confirmed, simulated")
    right.scatter([math.degrees(d[3])], [result.default_simulated[0] * M_TO_MM], marker="*", s=220, color="white",
                  edgecolors="black", label="default, simulated", zorder=3)
    right.set_xlabel("sheet yaw [deg]")
    right.set_ylabel("rms error of the part [mm]")
    right.grid(alpha=0.3)
    right.legend(fontsize=8)
    fig.suptitle(title or f"placement search: {len(rows)} candidates, {int(np.sum(ok))} feasible", fontsize=10)
    return save_figure(fig, path)
