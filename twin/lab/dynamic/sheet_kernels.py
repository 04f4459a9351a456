"""The dynamic plant's sheet in compiled code: `PlantSheet.force` and `advance` for every servo tick.

Operation for operation the Python methods of `twin.lab.dynamic.sheet` (kept as the reference;
`tests/test_plant_sheet.py` holds the two together), on the sheet's own arrays: the formed surface `z`
(ny, nx) and `pressed`, and the travel states as arrays (2,). The flow curve's exponential and power are the
C library's here and numpy's there: the two agree to a unit in the last place.
"""

# mypy: disable-error-code="arg-type, assignment, return-value"
from __future__ import annotations

import math

import numpy as np
from numba import njit

# the sheet's constants (`twin.lab.dynamic.sheet`), repeated for the compiled code; a test compares them
VOCE_S0_MPA, VOCE_Q_MPA, VOCE_B, VOCE_M = 130.2, 300.37, 3.94, 0.5
YOUNGS_MODULUS_PA, POISSON_RATIO = 71.0e9, 0.33
HALF_SIZE_M = 0.12
MIN_RECOVERY_M = 0.01e-3
FORMED_READ = 1.2
FORMED_PATCH = 0.6
FORMED_TRACK = 0.05
FORMED_GAIN = 2.0
HUNT_CROSSLEY_ALPHA_S_PER_M = 0.2
MAX_ANGLE_RAD = math.radians(70.0)
BAND_READS = 9
PLANE = 2.0 / math.sqrt(3.0)
FAR = 1e18  # a squared distance [nodes^2] no node of the grid is from another: no enclosed node in reach


@njit(cache=True)
def voce(eps: float) -> float:
    """`voce_mpa` of one strain [MPa]."""
    e = max(eps, 0.0)
    return VOCE_S0_MPA + VOCE_Q_MPA * (1.0 - math.exp(-VOCE_B * e)) ** VOCE_M


@njit(cache=True)
def height(z: np.ndarray, h: float, x: float, y: float) -> float:
    """`PlantSheet.height` on the grid of spacing `h` [m]."""
    fx = (x + HALF_SIZE_M) / h
    fy = (y + HALF_SIZE_M) / h
    ix, iy = math.floor(fx), math.floor(fy)
    if ix < 0 or iy < 0 or ix >= z.shape[1] - 1 or iy >= z.shape[0] - 1:
        return 0.0
    u, v = fx - ix, fy - iy
    low = z[iy, ix] * (1 - u) + z[iy, ix + 1] * u
    high = z[iy + 1, ix] * (1 - u) + z[iy + 1, ix + 1] * u
    return low * (1 - v) + high * v


@njit(cache=True)
def formed_fraction(pressed: np.ndarray, h: float, rho: float, x: float, y: float) -> float:
    """`PlantSheet.formed_fraction` (of `pressed`) or `hanging_share` (of `hanging`) over the disc of radius `rho` (the
    grid's spacing `h` [m])."""
    i0 = max(math.ceil((x - rho + HALF_SIZE_M) / h), 0)
    i1 = min(math.floor((x + rho + HALF_SIZE_M) / h), pressed.shape[1] - 1)
    j0 = max(math.ceil((y - rho + HALF_SIZE_M) / h), 0)
    j1 = min(math.floor((y + rho + HALF_SIZE_M) / h), pressed.shape[0] - 1)
    total = 0.0
    hit = 0.0
    for j in range(j0, j1 + 1):
        dy = (j * h - HALF_SIZE_M - y) / rho
        for i in range(i0, i1 + 1):
            dx = (i * h - HALF_SIZE_M - x) / rho
            q = 1.0 - dx * dx - dy * dy
            if q > 0.0:
                total += q * q
                if pressed[j, i]:
                    hit += q * q
    return hit / total if total > 0.0 else 0.0


@njit(cache=True)
def _pressed_outside(pressed: np.ndarray, outside: np.ndarray, j0: int, j1: int, i0: int, i1: int) -> bool:
    """Whether a node of rows j0..j1, columns i0..i1 was pressed since `outside` was flooded."""
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            if pressed[j, i] and outside[j, i]:
                return True
    return False


@njit(cache=True)
def _flood(pressed: np.ndarray, outside: np.ndarray, j0: int, j1: int, i0: int, i1: int) -> None:
    """`outside` over rows j0..j1, columns i0..i1 anew: the unpressed nodes a 4-connected flood of unpressed nodes
    reaches from the box's edge."""
    h, w = j1 - j0 + 1, i1 - i0 + 1
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            outside[j, i] = False
    stack = np.empty(h * w, dtype=np.int64)  # each node is pushed once at most
    top = 0
    for j in range(h):  # the box's edge: whole first and last rows, the ends of the others
        for i in range(0, w, 1 if j == 0 or j == h - 1 else max(w - 1, 1)):
            if not pressed[j0 + j, i0 + i]:
                outside[j0 + j, i0 + i] = True
                stack[top] = j * w + i
                top += 1
    while top > 0:
        top -= 1
        j, i = stack[top] // w, stack[top] % w
        for dj, di in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            jj, ii = j + dj, i + di
            if 0 <= jj < h and 0 <= ii < w and not outside[j0 + jj, i0 + ii] and not pressed[j0 + jj, i0 + ii]:
                outside[j0 + jj, i0 + ii] = True
                stack[top] = jj * w + ii
                top += 1


@njit(cache=True)
def fill(pressed: np.ndarray, box: np.ndarray, hanging: np.ndarray, regions: np.ndarray, reach: float) -> None:
    """`PlantSheet._fill` into `hanging`, kept with `regions` from the last call ((2, ny, nx): the enclosed nodes, all
    False on a fresh sheet; the outside ones, all True): the unpressed nodes joined to the clamped frame through
    unpressed nodes side by side (4-connected) are outside, the other unpressed nodes enclosed, and `hanging` is every
    node within `reach` nodes of an enclosed one (an exact squared distance transform, Felzenszwalb and Huttenlocher,
    "Distance transforms of sampled functions", Theory of Computing 8 (2012) 415-428). The outside is flooded again,
    from the edge of the pressed nodes' bounding box `box` (rows j0, j1, columns i0, i1) grown by one node (beyond it
    every node is unpressed and joined to the grid's edge), only when the tool pressed an outside node since: pressing
    no outside node leaves the outside as it was. `hanging` is found again only over the box of the nodes that turned
    enclosed or back, grown by `reach` (a node further from every changed node keeps the enclosed nodes in its reach,
    so its answer), from the enclosed nodes within `reach` of that box: the same answer as the whole grid's, at a
    fraction of the work once a part is deep."""
    ny, nx = pressed.shape
    j0, j1, i0, i1 = box[0], box[1], box[2], box[3]
    if j1 < 0:
        return
    j0, j1, i0, i1 = max(j0 - 1, 0), min(j1 + 1, ny - 1), max(i0 - 1, 0), min(i1 + 1, nx - 1)
    enclosed, outside = regions[0], regions[1]
    if _pressed_outside(pressed, outside, j0, j1, i0, i1):
        _flood(pressed, outside, j0, j1, i0, i1)
    d0, d1, c0, c1 = ny, -1, nx, -1  # the changed nodes' rows and columns: first, last (none: d1 < 0)
    for j in range(j0, j1 + 1):  # the box only grows: every node enclosed before lies in it
        for i in range(i0, i1 + 1):
            now = not outside[j, i] and not pressed[j, i]
            if now != enclosed[j, i]:
                enclosed[j, i] = now
                d0, d1, c0, c1 = min(d0, j), j, min(c0, i), max(c1, i)
    if d1 < 0:
        return
    g = math.ceil(reach)  # found again: rows r0..r1, columns a0..a1; read from the enclosed nodes g further out
    r0, r1, a0, a1 = max(d0 - g, 0), min(d1 + g, ny - 1), max(c0 - g, 0), min(c1 + g, nx - 1)
    b0, b1, e0, e1 = max(r0 - g, 0), min(r1 + g, ny - 1), max(a0 - g, 0), min(a1 + g, nx - 1)
    hb, wb = b1 - b0 + 1, e1 - e0 + 1
    d2 = np.empty((hb, wb))
    n = max(hb, wb)
    f = np.empty(n)
    out = np.empty(n)
    v = np.empty(n, dtype=np.int64)
    zb = np.empty(n + 1)
    for j in range(hb):  # along rows
        for i in range(wb):
            f[i] = 0.0 if enclosed[b0 + j, e0 + i] else FAR
        _edt_1d(f, wb, out, v, zb)
        for i in range(wb):
            d2[j, i] = out[i]
    for i in range(a0 - e0, a1 - e0 + 1):  # along the columns found again
        for j in range(hb):
            f[j] = d2[j, i]
        _edt_1d(f, hb, out, v, zb)
        for j in range(r0 - b0, r1 - b0 + 1):
            hanging[b0 + j, e0 + i] = out[j] <= reach * reach


@njit(cache=True)
def _edt_1d(f: np.ndarray, n: int, out: np.ndarray, v: np.ndarray, zb: np.ndarray) -> None:
    """The squared distance transform of the sampled function f[:n] into out[:n]: the lower envelope of the
    parabolas (q - p)^2 + f[p] (Felzenszwalb and Huttenlocher's algorithm DT)."""
    k = 0
    v[0] = 0
    zb[0], zb[1] = -1e300, 1e300
    for q in range(1, n):
        if f[q] >= FAR:
            continue
        if f[v[k]] >= FAR:
            v[k] = q
            continue
        s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k])
        while s <= zb[k]:
            k -= 1
            s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k])
        k += 1
        v[k] = q
        zb[k], zb[k + 1] = s, 1e300
    if f[v[0]] >= FAR:
        for q in range(n):
            out[q] = FAR
        return
    k = 0
    for q in range(n):
        while zb[k + 1] < q:
            k += 1
        out[q] = (q - v[k]) * (q - v[k]) + f[v[k]]


@njit(cache=True)
def membrane(scale: float, t0: float, alpha: float) -> float:
    """`PlantSheet.membrane_n_per_m`."""
    c = math.cos(alpha)
    eps = PLANE * math.log(1.0 / c)
    return PLANE * scale * voce(eps) * 1e6 * t0 * c


@njit(cache=True)
def springback(scale: float, depth: float, alpha: float) -> float:
    """`PlantSheet.springback_m`."""
    c = math.cos(alpha)
    sigma_phi = PLANE * scale * voce(PLANE * math.log(1.0 / c)) * 1e6
    return max(depth, 0.0) * sigma_phi * (1.0 - POISSON_RATIO**2) / YOUNGS_MODULUS_PA


@njit(cache=True)
def side_angle(z: np.ndarray, pressed: np.ndarray, h: float, r: float, cx: float, cy: float, near_s: float,
               near_o: float, hung_s: float, hung_o: float, x: float, y: float, zt: float, sx: float, sy: float,
               read: float, band: float) -> float:
    """One side's angle in `PlantSheet.force_reference`: its chord and slope (`PlantSheet._side_angles`), the
    slope dropped where its far read is the hanging bottom, flattened where the side is the hanging bottom; `near_s`,
    `hung_s` this side's near formed fraction and hanging share, `near_o`, `hung_o` the other side's (`force` reads
    each once); `read` [m] how far from the tip the chord is read, `band` [m] the half-width it is averaged over."""
    n = BAND_READS if band > 0.0 else 1
    chord = 0.0
    for i in range(n):  # n reads spread evenly from read - band to read + band (one: at read)
        k = read + band * (2.0 * i - (n - 1)) / max(n - 1, 1)
        chord += math.atan2(max(height(z, h, x + k * sx, y + k * sy) - zt, 0.0), k)
    chord /= n
    w1 = height(z, h, cx + r * sx, cy + r * sy)
    w2 = height(z, h, cx + 2.0 * r * sx, cy + 2.0 * r * sy)
    slope = math.atan2(max(w2 - w1, 0.0), r)
    rho = FORMED_PATCH * r
    far_s = formed_fraction(pressed, h, rho, cx + 2.0 * r * sx, cy + 2.0 * r * sy)
    on_bottom = min(1.0, max(0.0, FORMED_GAIN * (near_o - far_s - FORMED_TRACK)))
    bottom = min(1.0, max(0.0, FORMED_GAIN * (near_o - near_s - FORMED_TRACK)))
    bottom = max((1.0 - hung_o) * bottom, hung_s)
    return (1.0 - bottom) * min(max(chord, (1.0 - on_bottom) * slope), MAX_ANGLE_RAD)


@njit(cache=True)
def force(z: np.ndarray, pressed: np.ndarray, hanging: np.ndarray, h: float, r: float, t0: float, scale: float,
          mu: float, travel: np.ndarray, slip: np.ndarray, last: np.ndarray, dt: float, x: float, y: float, zt: float,
          out: np.ndarray, read: float, band: float) -> None:
    """`PlantSheet.force` into `out` (3,) [N]; `last` (3,) the committed tip [m]; `h` the grid's spacing [m]; `read`
    how far from the tip a side's chord is read, `band` the half-width it is averaged over [m]."""
    tx, ty = travel[0], travel[1]
    met = height(z, h, x + r * tx, y + r * ty) - zt
    cx, cy, cz = last[0], last[1], last[2]
    rho = FORMED_PATCH * r
    near0 = formed_fraction(pressed, h, rho, cx - FORMED_READ * r * ty, cy + FORMED_READ * r * tx)
    near1 = formed_fraction(pressed, h, rho, cx + FORMED_READ * r * ty, cy - FORMED_READ * r * tx)
    hung0 = formed_fraction(hanging, h, rho, cx - FORMED_READ * r * ty, cy + FORMED_READ * r * tx)
    hung1 = formed_fraction(hanging, h, rho, cx + FORMED_READ * r * ty, cy - FORMED_READ * r * tx)
    a0 = side_angle(z, pressed, h, r, cx, cy, near0, near1, hung0, hung1, x, y, zt, -ty, tx, read, band)
    a1 = side_angle(z, pressed, h, r, cx, cy, near1, near0, hung1, hung0, x, y, zt, ty, -tx, read, band)
    steep = max(a0, a1)  # one strip: the steeper side's tension and front contact
    n, w = membrane(scale, t0, steep), r * math.sin(steep)
    up = w * n * (math.sin(a0) + math.sin(a1))
    left = w * n * (math.cos(a0) - math.cos(a1))
    recovery = max(springback(scale, -zt, steep), MIN_RECOVERY_M)
    elastic = (met + recovery) / recovery
    rate = (cz - zt) / dt
    contact = min(1.0, max(0.0, elastic * (1.0 + 1.5 * HUNT_CROSSLEY_ALPHA_S_PER_M * rate)))
    if contact <= 0.0:
        out[0], out[1], out[2] = 0.0, 0.0, 0.0
        return
    fx, fy = -mu * up * slip[0], -mu * up * slip[1]
    out[0], out[1], out[2] = contact * (fx - left * ty), contact * (fy + left * tx), contact * up


@njit(cache=True)
def turned(state: np.ndarray, gain: float, dx: float, dy: float) -> None:
    """`_turned` in place: the state pushed by gain x the step, held to norm <= 1."""
    ox, oy = state[0] + gain * dx, state[1] + gain * dy
    norm = math.hypot(ox, oy)
    if norm > 1.0:
        ox, oy = ox / norm, oy / norm
    state[0], state[1] = ox, oy


@njit(cache=True)
def press(z: np.ndarray, pressed: np.ndarray, box: np.ndarray, x_m: np.ndarray, y_m: np.ndarray, h: float,
          r: float, half: int, x: float, y: float, zt: float) -> None:
    """`PlantSheet._press`: the grid (nodes `x_m`, `y_m`) lowered to the tool sphere's underside around the tip, the
    pressed nodes' bounding box `box` grown to the square pressed; `h` the grid's spacing [m]."""
    ix = int(np.rint((x + HALF_SIZE_M) / h))
    iy = int(np.rint((y + HALF_SIZE_M) / h))
    ny, nx = z.shape
    x0, x1 = max(ix - half, 0), min(ix + half + 1, nx)
    y0, y1 = max(iy - half, 0), min(iy + half + 1, ny)
    r2max = r * r
    for j in range(y0, y1):
        dy = y_m[j] - y
        for i in range(x0, x1):
            dx = x_m[i] - x
            r2 = dy * dy + dx * dx
            if r2 < r2max:
                under = zt + r - math.sqrt(r2max - r2)
                if under < z[j, i]:
                    z[j, i] = under
                pressed[j, i] = True
    if x0 < x1 and y0 < y1:
        box[0], box[1], box[2], box[3] = min(box[0], y0), max(box[1], y1 - 1), min(box[2], x0), max(box[3], x1 - 1)
