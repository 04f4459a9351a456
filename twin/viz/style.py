"""Shared style, input validation and atomic PNG writing of the figures (matplotlib, Agg).

Every figure function (`path_figures`, `deflection_figures`, `stiffness_figures`) validates its inputs with
these helpers, draws in millimetres / newtons / seconds (the code's SI arrays are converted there), writes
the PNG atomically (temporary file in the target directory, then `os.replace`), closes the figure and returns
the path written. Arrays of 3-vectors are sheet-frame (x, y, z); where a function only needs x and z it also
accepts (n, 2) arrays holding (x, z).
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from twin.base.csvio import make_folder
from twin.base.outputs import plain_mode, write_failure
from twin.errors import InputError

FIGSIZE_IN = (8.0, 5.0)
DPI = 120
M_TO_MM = 1e3
COLOR_IDEAL = "black"
COLOR_COMMANDED = "tab:orange"
COLOR_MEASURED = "tab:blue"
COLOR_SIMULATED = "tab:green"
COLOR_BEFORE = "tab:red"
COLOR_AFTER = "tab:green"
LEGEND_OUTSIDE = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "fontsize": 8}


def checked_array(name: str, values: object, ndim: int, columns: tuple[int, ...] = ()) -> np.ndarray:
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


def checked_xz(name: str, values: object) -> np.ndarray:
    """(n, 2) array of (x, z) from an (n, 3) sheet-frame array or an (n, 2) (x, z) array."""
    array = checked_array(name, values, 2, (2, 3))
    return array[:, [0, 2]] if array.shape[1] == 3 else array


def check_same_length(**arrays: np.ndarray) -> None:
    """InputError unless every array has the same number of samples (rows)."""
    lengths = {name: len(a) for name, a in arrays.items()}
    if len(set(lengths.values())) > 1:
        raise InputError(f"inputs must have the same number of samples, got {lengths}")


def save_figure(fig: Figure, path: str | Path) -> Path:
    """Write `fig` as PNG to `path` atomically and release it."""
    target = Path(path)
    make_folder(target.parent)
    tmp_name = target.parent / f".{target.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp"
    try:
        fig.savefig(tmp_name, dpi=DPI, format="png")
        plain_mode(tmp_name)
        os.replace(tmp_name, target)
    except BaseException as exc:
        tmp_name.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise write_failure(target, exc) from None
        raise
    finally:
        fig.clear()
    return target


def new_figure(
    nrows: int, *, sharex: bool = True, height_ratios: Sequence[float] | None = None
) -> tuple[Figure, list[Axes]]:
    """A figure of `nrows` stacked panels (one column), gridded, at `FIGSIZE_IN`."""
    fig = Figure(figsize=FIGSIZE_IN, layout="constrained")
    axes = fig.subplots(nrows, 1, sharex=sharex, squeeze=False, height_ratios=height_ratios)[:, 0]
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return fig, list(axes)
