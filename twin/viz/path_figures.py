"""Figures of the tool path in x-z (ideal, commanded, measured, with the vertical error), of the forming forces
against time, in the style of the thesis's Figs 3.10-3.11 and 5.1-5.2 (`twin.viz.style`), and of a replay: the
measured and the simulated tool tip's deviation from the command on each axis x, y, z against time.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from matplotlib.axes import Axes

from twin.errors import InputError
from twin.viz.style import (
    COLOR_COMMANDED,
    COLOR_IDEAL,
    COLOR_MEASURED,
    COLOR_SIMULATED,
    FIGSIZE_IN,
    LEGEND_OUTSIDE,
    M_TO_MM,
    check_same_length,
    checked_array,
    checked_xz,
    new_figure,
    save_figure,
)


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
    t_s = checked_array(name, values, 1)
    if len(t_s) != n:
        raise InputError(f"{name} has {len(t_s)} samples, its path {n}; expected equal")
    if np.any(np.diff(t_s) <= 0):
        raise InputError(f"{name} must be strictly increasing")
    return t_s


class _XzPaths(NamedTuple):
    """The checked paths of the x-z figure, sheet frame, as (x, z) [m], and their vertical errors [m]."""

    ideal_xz_m: np.ndarray  # (n, 2)
    measured_xz_m: np.ndarray  # (m, 2)
    commanded_xz_m: np.ndarray | None  # (k, 2)
    dz_measured_m: np.ndarray  # z(measured) - z(ideal), (m,)
    dz_commanded_m: np.ndarray | None  # z(commanded) - z(ideal), (k,)


def _checked_paths(
    p_ideal_sheet_m: object,
    p_measured_sheet_m: object,
    p_commanded_sheet_m: object | None,
    t_ideal_s: object | None,
    t_measured_s: object | None,
    t_commanded_s: object | None,
) -> _XzPaths:
    """Check the paths and their sample times, and pair each with the ideal path for its vertical error.

    Args:
        p_ideal_sheet_m: Ideal tool-tip path, sheet frame [m], shape (n, 3) or (n, 2).
        p_measured_sheet_m: Measured tool tip [m], shape (m, 3) or (m, 2).
        p_commanded_sheet_m: Commanded path [m], shape (k, 3) or (k, 2), or None.
        t_ideal_s: Sample times of the ideal path [s], shape (n,), or None.
        t_measured_s: Sample times of the measured path [s], shape (m,), or None.
        t_commanded_s: Sample times of the commanded path [s], shape (k,), or None.

    Returns:
        The paths as (x, z) [m] and z(path) - z(ideal) [m].

    Raises:
        InputError: Bad shapes, non-finite values, or paths that cannot be paired.
    """
    ideal = checked_xz("p_ideal_sheet_m", p_ideal_sheet_m)
    measured = checked_xz("p_measured_sheet_m", p_measured_sheet_m)
    commanded = None if p_commanded_sheet_m is None else checked_xz("p_commanded_sheet_m", p_commanded_sheet_m)
    t_ideal = _times("t_ideal_s", t_ideal_s, len(ideal))
    t_meas = _times("t_measured_s", t_measured_s, len(measured))
    err_meas = _paired_z_error("p_measured_sheet_m", measured, t_meas, ideal, t_ideal)
    err_cmd = None
    if commanded is not None:
        t_cmd = _times("t_commanded_s", t_commanded_s, len(commanded))
        err_cmd = _paired_z_error("p_commanded_sheet_m", commanded, t_cmd, ideal, t_ideal)
    return _XzPaths(ideal, measured, commanded, err_meas, err_cmd)


def _plot_paths(ax: Axes, paths: _XzPaths, title: str) -> None:
    """Upper panel: the ideal, commanded (when given) and measured paths in x-z [mm]."""
    ideal, measured, commanded = paths.ideal_xz_m, paths.measured_xz_m, paths.commanded_xz_m
    ax.plot(ideal[:, 0] * M_TO_MM, ideal[:, 1] * M_TO_MM, "--", color=COLOR_IDEAL, lw=1.2, label="ideal")
    if commanded is not None:
        ax.plot(
            commanded[:, 0] * M_TO_MM,
            commanded[:, 1] * M_TO_MM,
            ":",
            color=COLOR_COMMANDED,
            lw=1.2,
            label="commanded",
        )
    ax.plot(
        measured[:, 0] * M_TO_MM,
        measured[:, 1] * M_TO_MM,
        "-",
        color=COLOR_MEASURED,
        lw=0.9,
        label="measured",
    )
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("z [mm]")
    ax.set_title(title)
    ax.legend(**LEGEND_OUTSIDE)


def _plot_vertical_errors(ax: Axes, paths: _XzPaths) -> None:
    """Lower panel: z(path) - z(ideal) against x for the measured and (when given) commanded paths [mm]."""
    measured, commanded = paths.measured_xz_m, paths.commanded_xz_m
    err_meas, err_cmd = paths.dz_measured_m, paths.dz_commanded_m
    ax.axhline(0.0, color=COLOR_IDEAL, lw=0.8, ls="--")
    ax.plot(
        measured[:, 0] * M_TO_MM,
        err_meas * M_TO_MM,
        "-",
        color=COLOR_MEASURED,
        lw=0.8,
        label="measured - ideal",
    )
    if err_cmd is not None and commanded is not None:
        ax.plot(
            commanded[:, 0] * M_TO_MM,
            err_cmd * M_TO_MM,
            ":",
            color=COLOR_COMMANDED,
            lw=1.0,
            label="commanded - ideal",
        )
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("vertical error Δz [mm]")
    ax.set_title("Vertical error (magnified)", fontsize=9)
    ax.legend(**LEGEND_OUTSIDE)


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
    paths = _checked_paths(
        p_ideal_sheet_m, p_measured_sheet_m, p_commanded_sheet_m, t_ideal_s, t_measured_s, t_commanded_s
    )
    fig, (ax_path, ax_err) = new_figure(2, height_ratios=(3, 2))
    _plot_paths(ax_path, paths, title)
    _plot_vertical_errors(ax_err, paths)
    return save_figure(fig, path)


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
    t = checked_array("t_s", t_s, 1)
    f = checked_xz("f_measured_n", f_measured_n)
    check_same_length(t_s=t, f_measured_n=f)
    if (t_ideal_s is None) != (f_ideal_n is None):
        raise InputError("pass both t_ideal_s and f_ideal_n, or neither")
    ideal = None
    if t_ideal_s is not None:
        t_id = checked_array("t_ideal_s", t_ideal_s, 1)
        f_id = checked_xz("f_ideal_n", f_ideal_n)
        check_same_length(t_ideal_s=t_id, f_ideal_n=f_id)
        ideal = (t_id, f_id)

    fig, axes = new_figure(2)
    for k, (ax, name) in enumerate(zip(axes, ("Fx", "Fz"), strict=True)):
        ax.plot(t, f[:, k], "-", color=COLOR_MEASURED, lw=0.9, label=f"{name} measured")
        if ideal is not None:
            ax.plot(ideal[0], ideal[1][:, k], "--", color=COLOR_IDEAL, lw=1.0, label=f"{name} ideal (FE)")
        ax.set_ylabel(f"{name} [N]")
        ax.set_xlabel("time [s]")
        ax.legend(**LEGEND_OUTSIDE)
    axes[0].set_title(title)
    return save_figure(fig, path)


def plot_replay(
    path: str | Path,
    t_s: object,
    p_measured_sheet_m: object,
    p_simulated_sheet_m: object,
    p_commanded_sheet_m: object,
    *,
    title: str = "Replay: measured vs simulated tool tip, minus the command",
) -> Path:
    """A replay per axis: the measured and the simulated (twin) tool tip minus the commanded one, x, y and z
    [mm] against time [s], one panel each, with the rms gap of each axis in its legend.

    Args:
        path: PNG file to write (atomically).
        t_s: Sample times (the tracker's) [s], shape (n,).
        p_measured_sheet_m: Measured tool tip, sheet frame [m], shape (n, 3).
        p_simulated_sheet_m: The twin's predicted tool tip at the same times [m], shape (n, 3).
        p_commanded_sheet_m: The commanded tool tip at the same times [m], shape (n, 3).
        title: Figure title.

    Returns:
        The path written.

    Raises:
        InputError: Bad or mismatched shapes, non-finite values.
    """
    t = checked_array("t_s", t_s, 1)
    measured = checked_array("p_measured_sheet_m", p_measured_sheet_m, 2, (3,))
    simulated = checked_array("p_simulated_sheet_m", p_simulated_sheet_m, 2, (3,))
    commanded = checked_array("p_commanded_sheet_m", p_commanded_sheet_m, 2, (3,))
    check_same_length(t_s=t, p_measured_sheet_m=measured, p_simulated_sheet_m=simulated,
                      p_commanded_sheet_m=commanded)
    fig, axes = new_figure(3)
    fig.set_size_inches(FIGSIZE_IN[0], 1.4 * FIGSIZE_IN[1])
    for k, (ax, axis) in enumerate(zip(axes, "xyz", strict=True)):
        gap_mm = M_TO_MM * float(np.sqrt(np.mean((measured[:, k] - simulated[:, k]) ** 2)))
        ax.plot(t, M_TO_MM * (measured[:, k] - commanded[:, k]), "-", color=COLOR_MEASURED, lw=0.9,
                label="measured")
        ax.plot(t, M_TO_MM * (simulated[:, k] - commanded[:, k]), "-", color=COLOR_SIMULATED, lw=0.9,
                label=f"simulated (gap rms {gap_mm:.3f} mm)")
        ax.set_ylabel(f"{axis} - commanded [mm]")
        ax.set_xlabel("time [s]")
        ax.legend(**LEGEND_OUTSIDE)
    axes[0].set_title(title)
    return save_figure(fig, path)
