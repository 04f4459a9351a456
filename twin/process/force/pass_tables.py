"""Per-pass tables of an FE force history, for the sheet force field.

For every pass of the history: Fz_hist and the ratio Fx/Fz as PCHIP fits over x, the ideal path's height
z_plan and its reference depth δ_plan = z_ref - z_plan (z_ref the profile formed before the pass), tabulated on
a regular x grid and read back by linear interpolation (`lerp`, `lerp_slope`) in the per-sample hot path.
"""

from __future__ import annotations

import hashlib
import math
from collections import OrderedDict
from dataclasses import dataclass, replace

import numpy as np

from twin.errors import InputError
from twin.process.fe.load import ForceHistory
from twin.process.part.formed_profile import FormedProfile


@dataclass(frozen=True)
class PassTable:
    """One pass of the history on a regular x grid.

    Attributes:
        x0: First grid abscissa [m].
        dx: Grid spacing [m].
        n: Number of grid nodes.
        fz: Fz_hist [N], shape (n,).
        ratio: Fx_hist / max(Fz_hist, 1 N) [-], shape (n,).
        z_plan: Height of the ideal path [m], shape (n,).
        delta_plan: Reference depth of the ideal path, profile before the pass minus z_plan [m], shape (n,).
        direction: Travel direction of the pass along x, +1 or -1.
    """

    x0: float
    dx: float
    n: int
    fz: np.ndarray
    ratio: np.ndarray
    z_plan: np.ndarray
    delta_plan: np.ndarray
    direction: int


def lerp(table: np.ndarray, x0: float, dx: float, n: int, x: float) -> float:
    """Linear interpolation in a table on the grid x0 + dx·i, i < n, clamped at its ends [table unit]."""
    u = (x - x0) / dx
    if u <= 0.0:
        return float(table[0])
    if u >= n - 1:
        return float(table[n - 1])
    i = int(u)
    f = u - i
    return float(table[i] * (1.0 - f) + table[i + 1] * f)


def lerp_slope(table: np.ndarray, x0: float, dx: float, n: int, x: float) -> tuple[float, float]:
    """`lerp` (same arithmetic) and its slope d/dx (0 where the table is clamped) [table unit / m]."""
    u = (x - x0) / dx
    if u <= 0.0:
        return float(table[0]), 0.0
    if u >= n - 1:
        return float(table[n - 1]), 0.0
    i = int(u)
    f = u - i
    a, b = float(table[i]), float(table[i + 1])
    return a * (1.0 - f) + b * f, (b - a) / dx


def lerp_slope3(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, x0: float, dx: float, n: int, x: float
) -> tuple[float, float, float, float, float, float]:
    """`lerp_slope` of three tables on one grid at once (same arithmetic, one index computation).

    Returns:
        (a(x), a'(x), b(x), b'(x), c(x), c'(x)) [table unit, table unit / m].
    """
    u = (x - x0) / dx
    if u <= 0.0 or u >= n - 1:
        i = 0 if u <= 0.0 else n - 1
        return float(a[i]), 0.0, float(b[i]), 0.0, float(c[i]), 0.0
    i = int(u)
    f = u - i
    g = 1.0 - f
    a0, a1, b0, b1, c0, c1 = float(a[i]), float(a[i + 1]), float(b[i]), float(b[i + 1]), float(c[i]), float(c[i + 1])
    return a0 * g + a1 * f, (a1 - a0) / dx, b0 * g + b1 * f, (b1 - b0) / dx, c0 * g + c1 * f, (c1 - c0) / dx


def build_pass_tables(history: ForceHistory, profile: FormedProfile, *, deadband_m: float) -> list[PassTable]:
    """Tabulate every pass of `history`, driving `profile` along the history's own (ideal) samples.

    Before pass j the profile is snapshot (the reference of δ_plan), then pass j's samples are committed; on
    return `profile` holds the ideal path's formed profile.

    Args:
        history: Physical force history along the ideal path.
        profile: Formed profile to drive (normally flat on entry); its grid step is the tables' (at most: each
            pass's grid spans its x range exactly).
        deadband_m: Dead band for labelling the history's passes (`ForceHistory.pass_labels`) [m].

    Returns:
        One table per pass, passes 1..N in order.

    Raises:
        InputError: A pass with fewer than 2 distinct x samples.
    """
    from scipy.interpolate import PchipInterpolator  # scipy costs a second to import; only fitting needs it

    x, z = history.p_sheet_m[:, 0], history.p_sheet_m[:, 2]
    fx, fz = history.f_sheet_n[:, 0], history.f_sheet_n[:, 2]
    pass_index, direction = history.pass_labels(deadband_m)
    n_passes = int(pass_index.max())
    tables: list[PassTable] = []
    for j in range(1, n_passes + 1):
        sel = np.flatnonzero(pass_index == j)
        xs, order = np.unique(x[sel], return_index=True)
        if len(xs) < 2:
            raise InputError(f"{history.source}: pass {j} has fewer than 2 distinct x samples")
        sel = sel[order]
        n = max(2, math.ceil((xs[-1] - xs[0]) / profile.dx) + 1)
        grid = np.linspace(xs[0], xs[-1], n)
        fz_t = PchipInterpolator(xs, fz[sel])(grid)
        fx_t = PchipInterpolator(xs, fx[sel])(grid)
        # reference drive of the ideal path: profile before pass j, then commit pass j's samples
        profile.take_snapshot()
        z_plan = np.interp(grid, xs, z[sel])
        delta_plan = np.interp(grid, profile.x_grid_m, profile.snapshot_m) - z_plan
        for i in np.flatnonzero(pass_index == j):
            profile.commit(float(x[i]), float(z[i]))
        tables.append(
            PassTable(
                x0=float(grid[0]),
                dx=float(grid[1] - grid[0]),
                n=n,
                fz=fz_t,
                ratio=fx_t / np.maximum(fz_t, 1.0),
                z_plan=z_plan,
                delta_plan=delta_plan,
                direction=int(direction[sel[0]]),
            )
        )
    return tables


#: The tables built in this process, by what they are built from (`shared_pass_tables`); the most kept.
_SHARED: OrderedDict[tuple, list[PassTable]] = OrderedDict()
SHARED_MAX = 16


def shared_pass_tables(history: ForceHistory, radius_m: float, grid_step_m: float, half_length_m: float, *,
                       deadband_m: float) -> list[PassTable]:
    """`build_pass_tables` of `history` on a flat profile of that tool, grid and length, built once per process for
    each history (by its samples' bytes) and shared: every twin built from the same history fits the same tables
    (a discrepancy search builds a twin per candidate), and nothing changes them (their arrays are read-only).

    Args:
        history: Physical force history along the ideal path.
        radius_m: Tool sphere radius [m].
        grid_step_m: Spacing of the profile grid [m].
        half_length_m: The profile spans [-half_length_m, half_length_m] [m].
        deadband_m: Dead band for labelling the history's passes [m].
    """
    digest = hashlib.blake2b(digest_size=16)
    for array in (history.s_m, history.p_sheet_m, history.f_sheet_n):
        a = np.ascontiguousarray(array, dtype=float)
        digest.update(repr(a.shape).encode())
        digest.update(a.tobytes())
    key = (digest.hexdigest(), float(radius_m), float(grid_step_m), float(half_length_m), float(deadband_m))
    if key in _SHARED:
        _SHARED.move_to_end(key)
        return _SHARED[key]
    tables = build_pass_tables(history, FormedProfile(radius_m, grid_step_m, half_length_m), deadband_m=deadband_m)
    for t in tables:
        for a in (t.fz, t.ratio, t.z_plan, t.delta_plan):
            a.flags.writeable = False
    _SHARED[key] = tables
    if len(_SHARED) > SHARED_MAX:
        _SHARED.popitem(last=False)
    return tables


def scaled_tables(tables: list[PassTable], scale: float) -> list[PassTable]:
    """The tables of the history with every force times `scale` > 0, without refitting.

    PCHIP is homogeneous (the fit of s·F is s times the fit of F), so Fz scales; the ratio Fx / max(Fz, 1 N)
    changes only where s·Fz or Fz is below 1 N. Equal to `build_pass_tables` of the scaled history to rounding.
    """
    if not (math.isfinite(scale) and scale > 0.0):
        raise InputError(f"scale = {scale!r}: expected a finite number > 0")
    out = []
    for t in tables:
        fz = scale * t.fz
        ratio = t.ratio * scale * np.maximum(t.fz, 1.0) / np.maximum(fz, 1.0)
        out.append(replace(t, fz=fz, ratio=ratio))
    return out
