"""The deviation map of a formed part against its target (`twin.analysis.surface_check`), seen from above.

A scan on a grid (the labs' `part_scan.csv`) is drawn as an image; scattered points (a laser scan, registered)
as a triangulation, triangles longer than `GAP_SPACINGS` median point spacings left blank. With the regions of a design, the map
covers every region, the wall's edges are outlined and each region's numbers are listed. A part's stages on its
way to the design (`plot_part_stages`) are drawn side by side on one colour scale.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.cm import ScalarMappable
from matplotlib.figure import Figure
from matplotlib.tri import Triangulation
from scipy.spatial import cKDTree

from twin.analysis.part_compensation import PartStage, part_stats
from twin.analysis.scan_registration import ScanRegistration
from twin.analysis.surface_check import REGIONS, RegionDeviation, SurfaceDeviation
from twin.base.csvio import check_not_an_input
from twin.errors import InputError
from twin.viz.style import M_TO_MM, save_figure

GAP_SPACINGS = 6.0  # a triangle of scattered points longer than this many median spacings spans a gap: blank


def _draw(ax: Axes, xy: np.ndarray, dev: np.ndarray, limit: float, region: np.ndarray | None) -> ScalarMappable:
    """The map: an image for a grid, a triangulation otherwise; the wall's outline when regions are given."""
    xs, ix = np.unique(np.round(xy[:, 0], 4), return_inverse=True)
    ys, iy = np.unique(np.round(xy[:, 1], 4), return_inverse=True)
    tri = None
    if len(xs) * len(ys) <= 2 * len(xy):  # a grid
        image = np.full((len(ys), len(xs)), np.nan)
        image[iy, ix] = dev
        extent = (float(xs[0]), float(xs[-1]), float(ys[0]), float(ys[-1]))
        drawn: ScalarMappable = ax.imshow(image, origin="lower", extent=extent, aspect="equal", cmap="RdBu_r",
                                          vmin=-limit, vmax=limit)
    else:
        tri = Triangulation(xy[:, 0], xy[:, 1])
        spacing = float(np.median(cKDTree(xy).query(xy, k=2)[0][:, 1]))
        corners = xy[tri.triangles]
        longest = np.max(np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2), axis=1)
        tri.set_mask(longest > GAP_SPACINGS * spacing)
        drawn = ax.tripcolor(tri, dev, shading="gouraud", cmap="RdBu_r", vmin=-limit, vmax=limit)
    if region is not None and np.any(region == 0) and np.any(region != 0):
        tri = tri or Triangulation(xy[:, 0], xy[:, 1])
        ax.tricontour(tri, (region == 0).astype(float), levels=[0.5], colors="k", linewidths=0.6)
    return drawn


def plot_surface_deviation(
    path: str | Path,
    deviation: SurfaceDeviation,
    *,
    regions: RegionDeviation | None = None,
    registration: ScanRegistration | None = None,
    title: str = "",
    protect: Sequence[str | Path] = (),
) -> Path:
    """Write a PNG map of the scan's signed deviation from the target (+: shallower than the target) [mm].

    Args:
        path: Output PNG.
        deviation: The check's result over the formed region.
        regions: The deviations by region of a design: the map covers them all, with each region's numbers.
        registration: The scan's registration, named in the title.
        title: Title line above the numbers.
        protect: Inputs the figure must never overwrite.
    """
    target = Path(path)
    check_not_an_input(target, protect)
    shown = regions if regions is not None else deviation
    xy = shown.points_m[:, :2] * M_TO_MM
    dev = shown.deviation_m * M_TO_MM
    limit = float(max(np.max(np.abs(dev)), 1e-3))
    fig = Figure(figsize=(6.4, 5.6 if regions is not None else 5.2), layout="constrained")
    ax = fig.subplots()
    drawn = _draw(ax, xy, dev, limit, None if regions is None else regions.region)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    lines = [title] if title else []
    if registration is not None:
        angles = ", ".join(f"{v:+.3f}" for v in registration.rotation_deg)
        shift = ", ".join(f"{v:+.3f}" for v in registration.translation_m * M_TO_MM)
        lines.append(f"registered ({registration.datum} datum): rotation x, y, z {angles} deg,\ntranslation {shift} mm, "
                     f"best-fit rms {registration.residual_rms_m * M_TO_MM:.3f} mm"
                     + (f", free: {', '.join(registration.free)}" if registration.free else ""))
    lines.append(
        f"part scan - target: rms {deviation.rms_m * M_TO_MM:.3f} mm, max {deviation.max_abs_m * M_TO_MM:.3f} mm, "
        f"mean {deviation.mean_m * M_TO_MM:+.3f} mm"
    )
    ax.set_title("\n".join(lines), fontsize=7)
    if regions is not None:
        stats = regions.stats_mm()
        text = "\n".join(
            f"{name}: rms {s['rms_mm']:.3f}, max {s['max_mm']:.3f}, mean {s['mean_mm']:+.3f} mm"
            for name, s in ((n, stats[n]) for n in REGIONS if n in stats)
        )
        ax.text(0.01, 0.01, text, transform=ax.transAxes, fontsize=7, va="bottom", ha="left",
                bbox={"facecolor": "white", "alpha": 0.8, "linewidth": 0})
    fig.colorbar(drawn, ax=ax, label="deviation along the target's normal [mm] (+: too shallow)")
    return save_figure(fig, target)


def plot_part_stages(
    path: str | Path, stages: Sequence[PartStage], *, title: str = "", protect: Sequence[str | Path] = ()
) -> Path:
    """Write a PNG of the deviation maps of a part's stages side by side, on one colour scale [mm].

    Args:
        path: Output PNG.
        stages: The stages (`twin.analysis.part_compensation.PartStage`): predicted parts and scans, in order.
        title: The figure's title.
        protect: Inputs the figure must never overwrite.

    Raises:
        InputError: No stage.
    """
    target = Path(path)
    check_not_an_input(target, protect)
    if not stages:
        raise InputError("a stage figure needs at least one stage")
    limit = max(float(np.max(np.abs(s.deviation.deviation_m))) for s in stages) * M_TO_MM
    cols = min(len(stages), 3)
    rows = -(-len(stages) // cols)
    fig = Figure(figsize=(3.4 * cols + 0.8, 3.3 * rows + 0.4), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    drawn = None
    for ax, stage in zip(axes, stages, strict=False):
        dev = stage.deviation
        drawn = _draw(ax, dev.points_m[:, :2] * M_TO_MM, dev.deviation_m * M_TO_MM, max(limit, 1e-3), dev.region)
        part = part_stats(dev)["part"]
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm]", fontsize=7)
        ax.set_ylabel("y [mm]", fontsize=7)
        ax.set_title(f"{stage.name} ({stage.kind})\npart rms {part['rms_mm']:.3f} mm, mean {part['mean_mm']:+.3f} mm",
                     fontsize=7)
        ax.tick_params(labelsize=6)
    for ax in axes[len(stages):]:
        ax.set_axis_off()
    if title:
        fig.suptitle(title, fontsize=8)
    assert drawn is not None
    fig.colorbar(drawn, ax=list(axes), label="normal deviation [mm] (+: too shallow)", shrink=0.8)
    return save_figure(fig, target)
