"""Figures of runs and replays (matplotlib, Agg, PNG), in the style of the thesis's Figs 3.10-3.11, 5.1-5.2.

Every function validates its inputs, draws one figure in millimetres / newtons / seconds (the code's SI
arrays are converted here), writes it atomically (temporary file in the target directory, then
`os.replace`), closes it and returns the path written. Arrays of 3-vectors are sheet-frame (x, y, z);
where a function only needs x and z it also accepts (n, 2) arrays holding (x, z).
"""

from __future__ import annotations

import itertools
import os
import uuid
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np
from matplotlib.axes import Axes
from matplotlib.cm import ScalarMappable
from matplotlib.colors import BoundaryNorm
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from twin.errors import InputError

FIGSIZE_IN = (8.0, 5.0)
DPI = 120
M_TO_MM = 1e3
COLOR_IDEAL = "black"
COLOR_COMMANDED = "tab:orange"
COLOR_MEASURED = "tab:blue"
COLOR_BEFORE = "tab:red"
COLOR_AFTER = "tab:green"
LEGEND_OUTSIDE = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "fontsize": 8}


def _array(name: str, values: object, ndim: int, columns: tuple[int, ...] = ()) -> np.ndarray:
    """Float array with `ndim` dimensions (and one of `columns` columns when 2-D), finite, non-empty."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric, got {type(values).__name__}: {exc}") from None
    if array.ndim != ndim or (columns and array.shape[1] not in columns):
        want = "(n,)" if ndim == 1 else f"(n, {' or '.join(map(str, columns))})"
        raise InputError(f"{name} has shape {array.shape}, expected {want}")
    if array.shape[0] < 2:
        raise InputError(f"{name} has {array.shape[0]} sample(s), expected at least 2")
    if not np.all(np.isfinite(array)):
        raise InputError(f"{name} holds NaN or inf; expected finite values")
    return array


def _xz(name: str, values: object) -> np.ndarray:
    """(n, 2) array of (x, z) from an (n, 3) sheet-frame array or an (n, 2) (x, z) array."""
    array = _array(name, values, 2, (2, 3))
    return array[:, [0, 2]] if array.shape[1] == 3 else array


def _same_length(**arrays: np.ndarray) -> None:
    lengths = {name: len(a) for name, a in arrays.items()}
    if len(set(lengths.values())) > 1:
        raise InputError(f"inputs must have the same number of samples, got {lengths}")


def _save(fig: Figure, path: str | Path) -> Path:
    """Write `fig` as PNG to `path` atomically and release it."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp_name = target.parent / f".{target.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp"  # umask applies
    try:
        fig.savefig(tmp_name, dpi=DPI, format="png")
        os.replace(tmp_name, target)
    except BaseException:
        tmp_name.unlink(missing_ok=True)
        raise
    finally:
        fig.clear()
    return target


def _figure(
    nrows: int, *, sharex: bool = True, height_ratios: Sequence[float] | None = None
) -> tuple[Figure, list[Axes]]:
    fig = Figure(figsize=FIGSIZE_IN, layout="constrained")
    axes = fig.subplots(nrows, 1, sharex=sharex, squeeze=False, height_ratios=height_ratios)[:, 0]
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return fig, list(axes)


def _paired_z_error(
    name: str, xz: np.ndarray, t_s: np.ndarray | None, ideal_xz: np.ndarray, t_ideal_s: np.ndarray | None
) -> np.ndarray:
    """z of a path minus z of the ideal path at the same samples (same length) or times (interpolated) [m]."""
    if t_s is not None and t_ideal_s is not None:
        return xz[:, 1] - np.interp(t_s, t_ideal_s, ideal_xz[:, 1])
    if len(xz) != len(ideal_xz):
        raise InputError(
            f"{name} has {len(xz)} samples and the ideal path {len(ideal_xz)}: pass both sample-time arrays "
            "(t_ideal_s and the path's) to pair them in time, or equally sampled paths"
        )
    return xz[:, 1] - ideal_xz[:, 1]


def _times(name: str, values: object | None, n: int) -> np.ndarray | None:
    if values is None:
        return None
    t_s = _array(name, values, 1)
    if len(t_s) != n:
        raise InputError(f"{name} has {len(t_s)} samples, its path {n}; expected equal")
    if np.any(np.diff(t_s) <= 0):
        raise InputError(f"{name} must be strictly increasing")
    return t_s


def plot_path_xz(
    path: str | Path,
    p_ideal_sheet_m: object,
    p_measured_sheet_m: object,
    *,
    p_commanded_sheet_m: object | None = None,
    t_ideal_s: object | None = None,
    t_measured_s: object | None = None,
    t_commanded_s: object | None = None,
    title: str = "Tool path in the x-z plane: ideal vs measured",
) -> Path:
    """Ideal, measured (and commanded) tool path in x-z, with a lower panel of the vertical error.

    The lower panel shows z(path) - z(ideal) against x: at the same sample index when the paths are sampled
    alike, else interpolated in time (pass the `t_*_s` arrays), since mm errors vanish at groove scale.

    Args:
        path: PNG file to write.
        p_ideal_sheet_m: Ideal (FE) tool-tip path, sheet frame [m], shape (n, 3) or (n, 2) as (x, z).
        p_measured_sheet_m: Measured (tracker) tool tip [m], shape (m, 3) or (m, 2).
        p_commanded_sheet_m: Commanded path [m], shape (k, 3) or (k, 2), optional.
        t_ideal_s: Sample times of the ideal path [s], shape (n,), optional.
        t_measured_s: Sample times of the measured path [s], shape (m,), optional.
        t_commanded_s: Sample times of the commanded path [s], shape (k,), optional.
        title: Figure title.

    Returns:
        The path written.

    Raises:
        InputError: Bad shapes, non-finite values, or paths that cannot be paired for the error panel.
    """
    ideal = _xz("p_ideal_sheet_m", p_ideal_sheet_m)
    measured = _xz("p_measured_sheet_m", p_measured_sheet_m)
    commanded = None if p_commanded_sheet_m is None else _xz("p_commanded_sheet_m", p_commanded_sheet_m)
    t_ideal = _times("t_ideal_s", t_ideal_s, len(ideal))
    t_meas = _times("t_measured_s", t_measured_s, len(measured))
    err_meas = _paired_z_error("p_measured_sheet_m", measured, t_meas, ideal, t_ideal)
    err_cmd = None
    if commanded is not None:
        t_cmd = _times("t_commanded_s", t_commanded_s, len(commanded))
        err_cmd = _paired_z_error("p_commanded_sheet_m", commanded, t_cmd, ideal, t_ideal)

    fig, (ax_path, ax_err) = _figure(2, height_ratios=(3, 2))
    ax_path.plot(ideal[:, 0] * M_TO_MM, ideal[:, 1] * M_TO_MM, "--", color=COLOR_IDEAL, lw=1.2, label="ideal")
    if commanded is not None:
        ax_path.plot(
            commanded[:, 0] * M_TO_MM,
            commanded[:, 1] * M_TO_MM,
            ":",
            color=COLOR_COMMANDED,
            lw=1.2,
            label="commanded",
        )
    ax_path.plot(
        measured[:, 0] * M_TO_MM,
        measured[:, 1] * M_TO_MM,
        "-",
        color=COLOR_MEASURED,
        lw=0.9,
        label="measured",
    )
    ax_path.set_ylabel("z [mm]")
    ax_path.set_title(title)
    ax_path.legend(**LEGEND_OUTSIDE)

    ax_err.axhline(0.0, color=COLOR_IDEAL, lw=0.8, ls="--")
    ax_err.plot(
        measured[:, 0] * M_TO_MM,
        err_meas * M_TO_MM,
        "-",
        color=COLOR_MEASURED,
        lw=0.8,
        label="measured - ideal",
    )
    if err_cmd is not None and commanded is not None:
        ax_err.plot(
            commanded[:, 0] * M_TO_MM,
            err_cmd * M_TO_MM,
            ":",
            color=COLOR_COMMANDED,
            lw=1.0,
            label="commanded - ideal",
        )
    ax_err.set_xlabel("x [mm]")
    ax_err.set_ylabel("vertical error Δz [mm]")
    ax_err.set_title("Vertical error (magnified)", fontsize=9)
    ax_err.legend(**LEGEND_OUTSIDE)
    return _save(fig, path)


def plot_forces(
    path: str | Path,
    t_s: object,
    f_measured_n: object,
    *,
    t_ideal_s: object | None = None,
    f_ideal_n: object | None = None,
    title: str = "Forming forces: measured vs ideal (FE)",
) -> Path:
    """Fx and Fz against time, measured and (optionally) ideal, in two panels.

    Args:
        path: PNG file to write.
        t_s: Sample times of the measured force [s], shape (n,).
        f_measured_n: Force of the sheet on the tool [N], shape (n, 3) or (n, 2) as (Fx, Fz).
        t_ideal_s: Sample times of the ideal force [s], shape (m,); required with `f_ideal_n`.
        f_ideal_n: Ideal (FE) force [N], shape (m, 3) or (m, 2).
        title: Figure title.

    Returns:
        The path written.

    Raises:
        InputError: Bad shapes, non-finite values, or only one of `t_ideal_s` / `f_ideal_n`.
    """
    t = _array("t_s", t_s, 1)
    f = _xz("f_measured_n", f_measured_n)
    _same_length(t_s=t, f_measured_n=f)
    if (t_ideal_s is None) != (f_ideal_n is None):
        raise InputError("pass both t_ideal_s and f_ideal_n, or neither")
    ideal = None
    if t_ideal_s is not None:
        t_id = _array("t_ideal_s", t_ideal_s, 1)
        f_id = _xz("f_ideal_n", f_ideal_n)
        _same_length(t_ideal_s=t_id, f_ideal_n=f_id)
        ideal = (t_id, f_id)

    fig, axes = _figure(2)
    for k, (ax, name) in enumerate(zip(axes, ("Fx", "Fz"), strict=True)):
        ax.plot(t, f[:, k], "-", color=COLOR_MEASURED, lw=0.9, label=f"{name} measured")
        if ideal is not None:
            ax.plot(ideal[0], ideal[1][:, k], "--", color=COLOR_IDEAL, lw=1.0, label=f"{name} ideal (FE)")
        ax.set_ylabel(f"{name} [N]")
        ax.legend(**LEGEND_OUTSIDE)
    axes[0].set_title(title)
    axes[-1].set_xlabel("time [s]")
    return _save(fig, path)


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
    x = _array("x_m", x_m, 1)
    d = _xz("deflection_m", deflection_m)
    passes = _array("pass_index", pass_index, 1)
    dirs = _array("direction", direction, 1)
    _same_length(x_m=x, deflection_m=d, pass_index=passes, direction=dirs)
    if np.any(passes != np.round(passes)):
        raise InputError("pass_index must hold whole numbers")
    if not np.all(np.isin(dirs, (-1.0, 1.0))):
        raise InputError(f"direction must be +1 or -1, got values {np.unique(dirs)}")
    passes = passes.astype(int)

    unique = np.unique(passes)
    cmap = matplotlib.colormaps["viridis"]
    norm = BoundaryNorm(np.append(unique - 0.5, unique[-1] + 0.5), cmap.N)
    fig, axes = _figure(2)
    for start, stop in _segments(passes, dirs):
        style = "-" if dirs[start] > 0 else "--"
        color = cmap(norm(passes[start]))
        for k, ax in enumerate(axes):
            ax.plot(x[start:stop] * M_TO_MM, d[start:stop, k] * M_TO_MM, style, color=color, lw=1.0)
    axes[0].set_ylabel("x deflection [mm]")
    axes[1].set_ylabel("z deflection [mm]")
    axes[1].set_xlabel("x [mm]")
    axes[0].set_title(title)
    handles = [
        Line2D([], [], color="gray", ls="-", label="+x travel"),
        Line2D([], [], color="gray", ls="--", label="-x travel"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=8)
    bar = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=axes, ticks=unique, pad=0.01)
    bar.set_label("pass")
    return _save(fig, path)


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
    t = _array("t_s", t_s, 1)
    before = _array("residual_before_m", residual_before_m, 2, (2, 3))
    after = _array("residual_after_m", residual_after_m, 2, (2, 3))
    _same_length(t_s=t, residual_before_m=before, residual_after_m=after)
    if before.shape != after.shape:
        raise InputError(f"residuals have shapes {before.shape} and {after.shape}; expected equal")

    fig, (ax_norm, ax_z) = _figure(2)
    for res, label, color in ((before, label_before, COLOR_BEFORE), (after, label_after, COLOR_AFTER)):
        norm_mm = np.linalg.norm(res, axis=1) * M_TO_MM
        rms = float(np.sqrt(np.mean(norm_mm**2)))
        ax_norm.plot(t, norm_mm, "-", color=color, lw=0.9, label=f"{label} (RMS {rms:.3f} mm)")
        ax_z.plot(t, res[:, -1] * M_TO_MM, "-", color=color, lw=0.9, label=label)
    ax_z.axhline(0.0, color="black", lw=0.6)
    ax_norm.set_ylabel("|residual| [mm]")
    ax_z.set_ylabel("z residual [mm]")
    ax_z.set_xlabel("time [s]")
    ax_norm.set_title(title)
    ax_norm.legend(**LEGEND_OUTSIDE)
    ax_z.legend(**LEGEND_OUTSIDE)
    return _save(fig, path)


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
    return _save(fig, path)
