"""The `learned` force model's membrane terms in compiled code (`twin.process.force.learned`), for the ISF kernel.

Mirrors `LearnedForceField.features` and `_fz_linear` operation for operation; `tests/test_compiled_replay.py`
holds the two loops together.
"""

# mypy: disable-error-code="arg-type, assignment, return-value"
from __future__ import annotations

import math

from numba import njit

from twin.sim.compiled.isf_map import DIR_X, DIR_Y, IsfArrays, met_height


@njit(cache=True)
def _membrane(s: float, radius: float, cap: float) -> tuple:
    """`twin.process.force.learned._membrane`: (m(u), dm/ds, u³, d(u³)/ds)."""
    if s <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if s >= cap * radius:
        top = _membrane(0.999999 * cap * radius, radius, cap)
        return top[0], 0.0, top[2], 0.0
    q = s * s + radius * radius
    u = s / math.sqrt(q)
    du = radius * radius / q**1.5
    c = math.sqrt(max(1.0 - u * u, 1e-12))
    return u * u * c, (2.0 * u * c - u**3 / c) * du, u**3, 3.0 * u * u * du


@njit(cache=True)
def learned_terms(M: IsfArrays, x: float, y: float, z: float, lin: float, gx: float, gy: float, gz: float) -> tuple:
    """`LearnedForceField._fz_linear`: the prior's (lin, gradient) weighted, plus the membrane terms."""
    prm, radius = M.prm, M.prm[13]
    vx, vy = M.state[DIR_X], M.state[DIR_Y]
    speed = math.hypot(vx, vy)
    if speed > 1e-9:
        vx, vy = vx / speed, vy / speed
    else:
        vx, vy = 1.0, 0.0
    reach = prm[19] * radius
    side = side_x = side_y = side_z = cube = cube_x = cube_y = cube_z = 0.0
    ahead = ahead_x = ahead_y = ahead_z = 0.0
    for k in range(3):
        dx, dy = (-vy, vx) if k == 0 else ((vy, -vx) if k == 1 else (vx, vy))
        s, sx, sy = met_height(M, x + reach * dx, y + reach * dy)
        m, dm, c3, dc3 = _membrane(s - z, radius, prm[20])
        if k < 2:
            side, side_x, side_y, side_z = side + m, side_x + dm * sx, side_y + dm * sy, side_z - dm
            cube, cube_x, cube_y, cube_z = cube + c3, cube_x + dc3 * sx, cube_y + dc3 * sy, cube_z - dc3
        else:
            ahead, ahead_x, ahead_y, ahead_z = m, dm * sx, dm * sy, -dm
    w0, w1, w2, w3 = prm[15], prm[16], prm[17], prm[18]
    return (w0 * lin + w1 * side + w2 * cube + w3 * ahead, w0 * gx + w1 * side_x + w2 * cube_x + w3 * ahead_x,
            w0 * gy + w1 * side_y + w2 * cube_y + w3 * ahead_y, w0 * gz + w1 * side_z + w2 * cube_z + w3 * ahead_z)
