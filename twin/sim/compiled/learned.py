"""The `learned` force model's membrane and formed-state terms in compiled code (`twin.process.force.learned`), for the ISF kernel.

Mirrors `LearnedForceField.features` and `_fz_linear` operation for operation; `tests/test_compiled_replay.py`
holds the two loops together.
"""

# mypy: disable-error-code="arg-type, assignment, return-value"
from __future__ import annotations

import math

from numba import njit

from twin.process.force.learned import SATURATION_MM, STATE_FACTORS, STATE_TERMS
from twin.sim.compiled.isf_map import ALPHA, DIR_X, DIR_Y, RISE, IsfArrays, met_height

#: `SATURATION_MM`, unpacked: the kernel's base quantities are written for these three (a fourth fails here)
_D1, _D2, _D3 = SATURATION_MM


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
def _rise(s: float, radius: float, cap: float) -> tuple:
    """`twin.process.force.learned._rise`: (u, du/ds)."""
    if s <= 0.0:
        return 0.0, 0.0
    if s >= cap * radius:
        return _rise(0.999999 * cap * radius, radius, cap)[0], 0.0
    q = s * s + radius * radius
    return s / math.sqrt(q), radius * radius / q**1.5


@njit(cache=True)
def _contact(dh: float, width: float) -> tuple:
    """`twin.process.force.learned.contact_terms`: (E(Δz) [mm], σ(Δz), dσ/dΔz [1/m])."""
    a = dh / width
    if a < -40.0:
        return 0.0, 0.0, 0.0
    ex = math.exp(-abs(a))
    soft = (max(a, 0.0) + math.log1p(ex)) * width
    sig = 1.0 / (1.0 + ex) if a >= 0.0 else ex / (1.0 + ex)
    return 1e3 * soft, sig, sig * (1.0 - sig) / width


@njit(cache=True)
def learned_terms(M: IsfArrays, x: float, y: float, z: float, lin: float, gx: float, gy: float, gz: float) -> tuple:
    """`LearnedForceField._fz_linear`: the prior's (lin, gradient) weighted, plus the membrane and formed-state
    terms (their weights from `prm[21]` in the order of `STATE_KEYS` and `RISE_KEYS`, then the contact width and
    reference angle)."""
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
    n_state = STATE_TERMS.shape[0]
    r0, r1, r2 = prm[21 + n_state], prm[22 + n_state], prm[23 + n_state]
    f_rise = fx_rise = fy_rise = fz_rise = rise_sum = 0.0
    for k in range(3):
        dx, dy = (-vy, vx) if k == 0 else ((vy, -vx) if k == 1 else (vx, vy))
        s, sx, sy = met_height(M, x + reach * dx, y + reach * dy)
        m, dm, c3, dc3 = _membrane(s - z, radius, prm[20])
        u, du = _rise(s - z, radius, prm[20])
        wr = r2 if k == 2 else r0 + 2.0 * r1 * u  # the weight on du: the ahead rise's, or Σu's and Σu²'s
        f_rise += r2 * u if k == 2 else r0 * u + r1 * u * u
        fx_rise, fy_rise, fz_rise = fx_rise + wr * du * sx, fy_rise + wr * du * sy, fz_rise - wr * du
        if k < 2:
            rise_sum += u
            side, side_x, side_y, side_z = side + m, side_x + dm * sx, side_y + dm * sy, side_z - dm
            cube, cube_x, cube_y, cube_z = cube + c3, cube_x + dc3 * sx, cube_y + dc3 * sy, cube_z - dc3
        else:
            ahead, ahead_x, ahead_y, ahead_z = m, dm * sx, dm * sy, -dm
    M.state[RISE] = rise_sum  # `LearnedForceField._rise_sum`: the radial ratio's Σ u_s (`isf_eval`)
    w0, w1, w2, w3 = prm[15], prm[16], prm[17], prm[18]
    f = w0 * lin + w1 * side + w2 * cube + w3 * ahead + f_rise
    fx = w0 * gx + w1 * side_x + w2 * cube_x + w3 * ahead_x + fx_rise
    fy = w0 * gy + w1 * side_y + w2 * cube_y + w3 * ahead_y + fy_rise
    fz = w0 * gz + w1 * side_z + w2 * cube_z + w3 * ahead_z + fz_rise
    active = False
    for k in range(n_state):
        active = active or prm[21 + k] != 0.0
    if active:
        s, sx, sy = met_height(M, x, y)
        soft, sig, dsig = _contact(s - z, prm[24 + n_state])
        dz_depth = -1e3 if z < 0.0 else 0.0
        depth = 1e3 * max(-z, 0.0)
        e1, e2, e3 = math.exp(-depth / _D1), math.exp(-depth / _D2), math.exp(-depth / _D3)
        b = (lin, soft, sig, M.state[ALPHA] / prm[25 + n_state], depth, 1.0 - e1, 1.0 - e2, 1.0 - e3)
        bx = (gx, 1e3 * sig * sx, dsig * sx, 0.0, 0.0, 0.0, 0.0, 0.0)
        by = (gy, 1e3 * sig * sy, dsig * sy, 0.0, 0.0, 0.0, 0.0, 0.0)
        bz = (gz, -1e3 * sig, -dsig, 0.0, dz_depth, e1 / _D1 * dz_depth, e2 / _D2 * dz_depth, e3 / _D3 * dz_depth)
        for k in range(n_state):
            w = prm[21 + k] * STATE_FACTORS[k]
            if w == 0.0:
                continue
            value, tx, ty, tz = 1.0, 0.0, 0.0, 0.0
            for i in range(3):  # product rule, one factor at a time
                fi = STATE_TERMS[k, i]
                if fi < 0:
                    continue
                tx, ty, tz = tx * b[fi] + value * bx[fi], ty * b[fi] + value * by[fi], tz * b[fi] + value * bz[fi]
                value *= b[fi]
            f += w * value
            fx += w * tx
            fy += w * ty
            fz += w * tz
    return f, fx, fy, fz
