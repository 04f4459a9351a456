"""Figures of deflections and residuals: the tool deflection along the groove, one line per pass, and a
position residual before and after a fix (`twin.viz.style`).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colors import BoundaryNorm
from matplotlib.lines import Line2D

from twin.errors import InputError
from twin.viz.style import (
    COLOR_AFTER,
    COLOR_BEFORE,
    LEGEND_OUTSIDE,
    M_TO_MM,
    check_same_length,
    checked_array,
    checked_xz,
    new_figure,
    save_figure,
)


def _segments(pass_index: np.ndarray, direction: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index ranges over which pass and direction stay constant."""
    change = np.flatnonzero((np.diff(pass_index) != 0) | (np.diff(direction) != 0)) + 1
    bounds = [0, *change.tolist(), len(pass_index)]
    return list(itertools.pairwise(bounds))


def plot_deflection_by_pass(
    path: str | Path,
    x_m: object,
    deflection_m: object,
    pass_index: object,
    direction: object,
    *,
    title: str = "Tool deflection along the groove, by pass",
) -> Path:
    """x and z deflection against x, one line per pass (colour), solid for +x travel and dashed for -x.

    Args:
        path: PNG file to write.
        x_m: Tool x position, sheet frame [m], shape (n,).
        deflection_m: Deflection (loaded - unloaded or measured - commanded) [m], shape (n, 3) or (n, 2).
        pass_index: Pass number per sample (1-based), shape (n,).
        direction: Travel direction along x per sample (+1 / -1), shape (n,).
        title: Figure title.

    Returns:
        The path written.

    Raises:
        InputError: Bad shapes, non-finite values, non-integer passes or directions other than +/-1.
    """
    x = checked_array("x_m", x_m, 1)
    d = checked_xz("deflection_m", deflection_m)
    passes = checked_array("pass_index", pass_index, 1)
    dirs = checked_array("direction", direction, 1)
    check_same_length(x_m=x, deflection_m=d, pass_index=passes, direction=dirs)
    if np.any(passes != np.round(passes)):
        raise InputError("pass_index must hold whole numbers")
    if not np.all(np.isin(dirs, (-1.0, 1.0))):
        raise InputError(f"direction must be +1 or -1, got values {np.unique(dirs)}")
    passes = passes.astype(int)

    unique = np.unique(passes)
    cmap = matplotlib.colormaps["viridis"]
    norm = BoundaryNorm(np.append(unique - 0.5, unique[-1] + 0.5), cmap.N)
    fig, axes = new_figure(2)
    for start, stop in _segments(passes, dirs):
        style = "-" if dirs[start] > 0 else "--"
        color = cmap(norm(passes[start]))
        for k, ax in enumerate(axes):
            ax.plot(x[start:stop] * M_TO_MM, d[start:stop, k] * M_TO_MM, style, color=color, lw=1.0)
    axes[0].set_ylabel("x deflection [mm]")
    axes[1].set_ylabel("z deflection [mm]")
    for ax in axes:
        ax.set_xlabel("x [mm]")
    axes[0].set_title(title)
    handles = [
        Line2D([], [], color="gray", ls="-", label="+x travel"),
        Line2D([], [], color="gray", ls="--", label="-x travel"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=8)
    bar = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=axes, ticks=unique, pad=0.01)
    bar.set_label("pass [-]")
    return save_figure(fig, path)


def plot_residual_before_after(
    path: str | Path,
    t_s: object,
    residual_before_m: object,
    residual_after_m: object,
    *,
    label_before: str = "before",
    label_after: str = "after",
    title: str = "Residual (measured - predicted) before and after",
) -> Path:
    """Norm and z component of a position residual against time, before and after a fix.

    Args:
        path: PNG file to write.
        t_s: Sample times [s], shape (n,).
        residual_before_m: Residual before the fix [m], shape (n, 3) or (n, 2) as (x, z).
        residual_after_m: Residual after the fix [m], same shape.
        label_before: Legend label of the first residual.
        label_after: Legend label of the second residual.
        title: Figure title.

    Returns:
        The path written.

    Raises:
        InputError: Bad or mismatched shapes, non-finite values.
    """
    t = checked_array("t_s", t_s, 1)
    before = checked_array("residual_before_m", residual_before_m, 2, (2, 3))
    after = checked_array("residual_after_m", residual_after_m, 2, (2, 3))
    check_same_length(t_s=t, residual_before_m=before, residual_after_m=after)
    if before.shape != after.shape:
        raise InputError(f"residuals have shapes {before.shape} and {after.shape}; expected equal")

    fig, (ax_norm, ax_z) = new_figure(2)
    for res, label, color in ((before, label_before, COLOR_BEFORE), (after, label_after, COLOR_AFTER)):
        norm_mm = np.linalg.norm(res, axis=1) * M_TO_MM
        rms = float(np.sqrt(np.mean(norm_mm**2)))
        ax_norm.plot(t, norm_mm, "-", color=color, lw=0.9, label=f"{label} (RMS {rms:.3f} mm)")
        ax_z.plot(t, res[:, -1] * M_TO_MM, "-", color=color, lw=0.9, label=label)
    ax_z.axhline(0.0, color="black", lw=0.6)
    ax_norm.set_ylabel("|residual| [mm]")
    ax_z.set_ylabel("z residual [mm]")
    ax_norm.set_xlabel("time [s]")
    ax_z.set_xlabel("time [s]")
    ax_norm.set_title(title)
    ax_norm.legend(**LEGEND_OUTSIDE)
    ax_z.legend(**LEGEND_OUTSIDE)
    return save_figure(fig, path)
