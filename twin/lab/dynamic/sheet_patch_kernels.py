"""The dynamic plant's second sheet law in compiled code: `PatchSheet.force` and `advance` for every servo tick.

Operation for operation the Python methods of `twin.lab.dynamic.sheet_patch` (kept as the reference;
`tests/test_plant_sheet_law2.py` holds the two together), on the sheet's own arrays: the formed surface `z`
(ny, nx), the nodes' thinning strain `strain` (ny, nx) and the slip state (2,). The power and exponential are the
C library's here and numpy's there: the two agree to a few units in the last place.
"""

# mypy: disable-error-code="arg-type, assignment, return-value"
from __future__ import annotations

import math

import numpy as np
from numba import njit

# the law's constants (`twin.lab.dynamic.sheet_patch`), repeated for the compiled code; a test compares them
SWIFT_K_MPA, SWIFT_EPS0, SWIFT_N = 576.79, 0.01658, 0.3593
YOUNGS_MODULUS_PA, POISSON_RATIO = 71.0e9, 0.33
HALF_SIZE_M = 0.12
DAMPING_TIME_S = 2e-5
MIN_NORMAL_Z = math.cos(math.radians(70.0))
MAX_SLOPE = math.tan(math.radians(45.0))
PLANE = 2.0 / math.sqrt(3.0)
HANG_SLOPE = math.tan(math.radians(10.0))


@njit(cache=True)
def node_law(strain: float, r: float, t0: float, scale: float) -> tuple[float, float]:
    """`PatchSheet.node_law`: (foundation stiffness [Pa/m], cap pressure [Pa]) of a node of thinning `strain`."""
    t = t0 * math.exp(-strain)
    sigma = scale * SWIFT_K_MPA * (SWIFT_EPS0 + strain) ** SWIFT_N * 1e6
    membrane = 2.0 * YOUNGS_MODULUS_PA * t / ((1.0 - POISSON_RATIO) * r * r)
    plate = 64.0 * YOUNGS_MODULUS_PA * t * t * t / (12.0 * (1.0 - POISSON_RATIO * POISSON_RATIO) * r**4)
    stiffness = 1.0 / (1.0 / membrane + 1.0 / plate)
    return stiffness, PLANE * sigma * t / r


@njit(cache=True)
def force(z: np.ndarray, strain: np.ndarray, x_m: np.ndarray, y_m: np.ndarray, h: float, r: float, t0: float,
          scale: float, mu: float, slip: np.ndarray, last: np.ndarray, rate_gain: float, half: int, x: float, y: float,
          zt: float, out: np.ndarray) -> None:
    """`PatchSheet.force` into `out` (3,) [N]; `last` the previous committed tip (3,), `rate_gain` tau / dt [-], `h`
    the grid's spacing [m]."""
    ix = int(np.rint((x + HALF_SIZE_M) / h))
    iy = int(np.rint((y + HALF_SIZE_M) / h))
    ny, nx = z.shape
    x0, x1 = max(ix - half, 0), min(ix + half + 1, nx)
    y0, y1 = max(iy - half, 0), min(iy + half + 1, ny)
    zc, lzc = zt + r, last[2] + r
    area = h * h
    sx, sy = slip[0], slip[1]
    fx, fy, fz = 0.0, 0.0, 0.0
    for j in range(y0, y1):
        dy = y_m[j] - y
        ly = y_m[j] - last[1]
        for i in range(x0, x1):
            dx = x_m[i] - x
            dz = z[j, i] - zc
            dist = math.sqrt(dx * dx + dy * dy + dz * dz)
            depth = r - dist
            if depth <= 0.0:
                continue
            lx = x_m[i] - last[0]
            lz = z[j, i] - lzc
            before = r - math.sqrt(lx * lx + ly * ly + lz * lz)
            stiffness, cap = node_law(strain[j, i], r, t0, scale)
            p = stiffness * (depth + rate_gain * (depth - before))
            p = max(min(p, cap), 0.0)
            nxn, nyn, nzn = -dx / dist, -dy / dist, -dz / dist
            fn = p * area / max(nzn, MIN_NORMAL_Z)
            along = sx * nxn + sy * nyn
            fx += fn * (nxn - mu * (sx - along * nxn))
            fy += fn * (nyn - mu * (sy - along * nyn))
            fz += fn * (nzn - mu * (-along * nzn))
    out[0], out[1], out[2] = fx, fy, fz


@njit(cache=True)
def yield_nodes(z: np.ndarray, strain: np.ndarray, yielded: np.ndarray, x_m: np.ndarray, y_m: np.ndarray, h: float,
                r: float, t0: float, scale: float, half: int, k: int, x: float, y: float, zt: float) -> None:
    """`PatchSheet._yield`: the nodes pressed past the cap lowered to it, the sheet never yielded hung from them;
    the thinning strain updated, its slope over `k` spacings `h` [m] either side (`PatchSheet.strain_step`)."""
    ix = int(np.rint((x + HALF_SIZE_M) / h))
    iy = int(np.rint((y + HALF_SIZE_M) / h))
    ny, nx = z.shape
    x0, x1 = max(ix - half, 0), min(ix + half + 1, nx)
    y0, y1 = max(iy - half, 0), min(iy + half + 1, ny)
    zc = zt + r
    for j in range(y0, y1):
        dy = y_m[j] - y
        for i in range(x0, x1):
            dx = x_m[i] - x
            dz = z[j, i] - zc
            dist = math.sqrt(dx * dx + dy * dy + dz * dz)
            stiffness, cap = node_law(strain[j, i], r, t0, scale)
            reach = r - cap / stiffness  # the sphere less the elastic penetration at the cap
            if dist < reach:
                z[j, i] = zc - math.sqrt(reach * reach - dx * dx - dy * dy)
                yielded[j, i] = True
    rise = h * HANG_SLOPE
    for j in range(max(y0, 1), min(y1, ny - 1)):  # forward sweep: no never-yielded node above a neighbour by more
        for i in range(max(x0, 1), min(x1, nx - 1)):
            low = min(min(z[j, i - 1], z[j, i + 1]), min(z[j - 1, i], z[j + 1, i])) + rise
            if low < z[j, i] and not yielded[j, i]:
                z[j, i] = low
    for j in range(min(y1, ny - 1) - 1, max(y0, 1) - 1, -1):  # backward sweep
        for i in range(min(x1, nx - 1) - 1, max(x0, 1) - 1, -1):
            low = min(min(z[j, i - 1], z[j, i + 1]), min(z[j - 1, i], z[j + 1, i])) + rise
            if low < z[j, i] and not yielded[j, i]:
                z[j, i] = low
    for j in range(max(y0 - k, k), min(y1 + k, ny - k)):
        for i in range(max(x0 - k, k), min(x1 + k, nx - k)):
            gx = (z[j, i + k] - z[j, i - k]) / (2.0 * k * h)
            gy = (z[j + k, i] - z[j - k, i]) / (2.0 * k * h)
            slope = min(math.sqrt(gx * gx + gy * gy), MAX_SLOPE)
            e = 0.5 * math.log(1.0 + slope * slope)
            if e > strain[j, i]:
                strain[j, i] = e
