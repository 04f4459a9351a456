"""Figure of Cartesian compliances as deflection ellipses: the image of the 1 kN force circle in x-z
(`twin.viz.style`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from twin.errors import InputError
from twin.viz.style import FIGSIZE_IN, save_figure


def _checked_compliances(
    compliance_xz_mm_per_kn_list: Sequence[object], labels: Sequence[str]
) -> list[np.ndarray]:
    """The compliances as finite (2, 2) arrays [mm/kN], one per label.

    Args:
        compliance_xz_mm_per_kn_list: Compliances C [mm/kN], each shape (2, 2), rows (x, z), columns (Fx, Fz).
        labels: One legend label per compliance.

    Returns:
        The matrices, in order.

    Raises:
        InputError: The list is empty, labels do not match, or a compliance is not a finite (2, 2) matrix.
    """
    if len(compliance_xz_mm_per_kn_list) == 0:
        raise InputError("need at least one compliance matrix")
    if len(labels) != len(compliance_xz_mm_per_kn_list):
        raise InputError(
            f"got {len(compliance_xz_mm_per_kn_list)} compliances and {len(labels)} labels; expected equal"
        )
    matrices = []
    for i, c in enumerate(compliance_xz_mm_per_kn_list):
        matrix = np.asarray(c, dtype=float)
        if matrix.shape != (2, 2) or not np.all(np.isfinite(matrix)):
            raise InputError(f"compliance {i} ({labels[i]!r}) must be a finite (2, 2) matrix, got {matrix!r}")
        matrices.append(matrix)
    return matrices


def plot_stiffness_ellipse(
    path: str | Path,
    compliance_xz_mm_per_kn_list: Sequence[object],
    labels: Sequence[str],
    *,
    title: str = "Deflection under a 1 kN force of any direction in x-z",
) -> Path:
    """Deflection ellipses: the image of the 1 kN force circle under each x-z compliance, overlaid.

    Markers show the deflection under +1 kN along x (square) and +1 kN along z (dot).

    Args:
        path: PNG file to write.
        compliance_xz_mm_per_kn_list: Compliances C (deflection = C·F) [mm/kN], each shape (2, 2),
            rows (x, z), columns (Fx, Fz).
        labels: One legend label per compliance.
        title: Figure title.

    Returns:
        The path written.

    Raises:
        InputError: A compliance is not a finite (2, 2) matrix, the list is empty, or labels do not match.
    """
    matrices = _checked_compliances(compliance_xz_mm_per_kn_list, labels)
    angle = np.linspace(0.0, 2.0 * np.pi, 361)
    unit_kn = np.vstack([np.cos(angle), np.sin(angle)])
    fig = Figure(figsize=FIGSIZE_IN, layout="constrained")
    ax = fig.subplots()
    ax.grid(True, alpha=0.3)
    colors = matplotlib.colormaps["tab10"]
    for i, (matrix, label) in enumerate(zip(matrices, labels, strict=True)):
        color = colors(i % 10)
        curve = matrix @ unit_kn
        ax.plot(curve[0], curve[1], "-", color=color, lw=1.4, label=label)
        ax.plot(*matrix[:, 0], "s", color=color, ms=5)
        ax.plot(*matrix[:, 1], "o", color=color, ms=5)
    ax.plot(0.0, 0.0, "+", color="black", ms=8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x deflection [mm]")
    ax.set_ylabel("z deflection [mm]")
    ax.set_title(title)
    marker_handles = [
        Line2D([], [], color="gray", marker="s", ls="", label="+1 kN along x"),
        Line2D([], [], color="gray", marker="o", ls="", label="+1 kN along z"),
    ]
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(handles=[*handles, *marker_handles], loc="center left", bbox_to_anchor=(1.02, 0.5), fontsize=8)
    return save_figure(fig, path)
