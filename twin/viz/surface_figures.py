"""The deviation map of a formed part against its target (`twin.analysis.surface_check`), seen from above."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from twin.analysis.surface_check import SurfaceDeviation
from twin.base.csvio import check_not_an_input
from twin.viz.style import M_TO_MM, save_figure


def plot_surface_deviation(
    path: str | Path, deviation: SurfaceDeviation, *, title: str = "", protect: Sequence[str | Path] = ()
) -> Path:
    """Write a PNG map of the scan's signed deviation from the target (+: shallower than the target) [mm].

    Args:
        path: Output PNG.
        deviation: The check's result.
        title: Title line above the numbers.
        protect: Inputs the figure must never overwrite.
    """
    target = Path(path)
    check_not_an_input(target, protect)
    xy = deviation.points_m[:, :2] * M_TO_MM
    dev = deviation.deviation_m * M_TO_MM
    limit = float(max(np.max(np.abs(dev)), 1e-3))
    fig = Figure(figsize=(6.4, 5.2), layout="constrained")
    ax = fig.subplots()
    xs, ix = np.unique(np.round(xy[:, 0], 4), return_inverse=True)  # a scan on a grid: drawn as an image
    ys, iy = np.unique(np.round(xy[:, 1], 4), return_inverse=True)
    image = np.full((len(ys), len(xs)), np.nan)
    image[iy, ix] = dev
    extent = (float(xs[0]), float(xs[-1]), float(ys[0]), float(ys[-1]))
    dots = ax.imshow(image, origin="lower", extent=extent, cmap="RdBu_r", vmin=-limit, vmax=limit, aspect="equal")
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(
        (title + "\n" if title else "")
        + f"part scan - target: rms {deviation.rms_m * M_TO_MM:.3f} mm, max {deviation.max_abs_m * M_TO_MM:.3f} mm, "
        f"mean {deviation.mean_m * M_TO_MM:+.3f} mm",
        fontsize=9,
    )
    fig.colorbar(dots, ax=ax, label="deviation along the target's normal [mm] (+: too shallow)")
    return save_figure(fig, target)
