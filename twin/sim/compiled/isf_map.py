"""The ISF model's arrays in compiled code, and its met surface read on them (`twin.sim.compiled.isf`)."""

# mypy: disable-error-code="arg-type, assignment, return-value"
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from twin.process.force.learned import WEIGHT_KEYS

# state slots
DIR_X, DIR_Y, HAS_LAST, LAST_X, LAST_Y, LAST_Z, ALPHA, COUNT, Q_HEAD, TRAVEL, SIDE, RISE = range(12)
#: the slots of `IsfArrays.state`
STATE_SLOTS = 12
#: the slot of `prm` that holds the learned model's μ_ρ (`twin.process.force.learned.RADIAL_RISE_KEY`): after the
#: ISF constants (14), the learned flag, the weights, reach, cap, contact width and reference angle
RADIAL_RISE = 19 + len(WEIGHT_KEYS)
# track columns: x, y, z, f_z, parent, travel at the commit, has a patch on the grid
TX, TY, TZ, TF, TP, TS, TW = range(7)


class IsfArrays(NamedTuple):
    """An `IsfForceField` and its height map as flat arrays."""

    z_met: np.ndarray  # (ny, nx) met surface [m] (the Python map's array)
    owner: np.ndarray  # (ny, nx) owner commit, -1 never formed (the Python map's array)
    templates: np.ndarray  # (S+1, S+1, w, w) R - sqrt(R² - ρ²) per snapped sub-cell offset, inf outside [m]
    track: np.ndarray  # (capacity, 7) commits
    grid: np.ndarray  # (x0, y0, h, nx, ny, half window, lag, substeps)
    prm: np.ndarray  # (base, α_max, D0, Δz_min, k_unload, μ_t, L_f, alpha length, wall baseline, max layers, L_r,
    #                   μ_r, least wall run, R, has learned terms, w, a_side, b_side, a_ahead, reach, cap,
    #                   the formed-state and rise weights, contact width, reference angle, μ_ρ)
    state: np.ndarray  # (STATE_SLOTS,) see the slots above (RISE: Σ u_s at the last evaluated tip)


@njit(cache=True)
def met_height(M: IsfArrays, x: float, y: float) -> tuple:
    """`HeightMap.met_height`: bilinear value and slopes, clamped at the grid edge."""
    x0, y0, h, nx, ny = M.grid[0], M.grid[1], M.grid[2], int(M.grid[3]), int(M.grid[4])
    u = min(max((x - x0) / h, 0.0), nx - 1.000000001)
    v = min(max((y - y0) / h, 0.0), ny - 1.000000001)
    i, j = int(u), int(v)
    fu, fv = u - i, v - j
    t = M.z_met
    a, b, c, d = t[j, i], t[j, i + 1], t[j + 1, i], t[j + 1, i + 1]
    value = (a * (1 - fu) + b * fu) * (1 - fv) + (c * (1 - fu) + d * fu) * fv
    return value, ((b - a) * (1 - fv) + (d - c) * fv) / h, ((c - a) * (1 - fu) + (d - b) * fu) / h


@njit(cache=True)
def met_owner(M: IsfArrays, x: float, y: float) -> int:
    x0, y0, h, nx, ny = M.grid[0], M.grid[1], M.grid[2], int(M.grid[3]), int(M.grid[4])
    ix = int((x - x0) / h + 0.5)
    iy = int((y - y0) / h + 0.5)
    if 0 <= ix < nx and 0 <= iy < ny and x >= x0 and y >= y0:
        return M.owner[iy, ix]
    return -1
