"""The height-map ISF force model in compiled code for the replay loop (any part: cones, pyramids, G-code).

Mirrors `twin.process.force.isf.IsfForceField` (`force_and_stiffness`, `force`, `advance`) and its
`twin.process.part.heightmap.HeightMap` (met surface with its lag, owners, track, envelope templates) operation for
operation; `tests/test_compiled_replay.py` holds the replays together. The map's surface and owner arrays are
the Python map's own, changed in place; `write_back` returns the rest of the state (track, travel, pending
commits, travel direction, wall angle) to the Python objects after a replay.

The pending commits (the lag: the sphere's last positions do not yet belong to the surface the tool meets) are
the track entries from `state[Q_HEAD]` on, as the Python map's queue holds them.
"""

# mypy: disable-error-code="arg-type, assignment, return-value"
from __future__ import annotations

import math

import numpy as np
from numba import njit

from twin.process.force import isf as isf_force
from twin.process.force import learned as learned_force
from twin.process.force import sliding
from twin.process.force.isf import IsfForceField, IsfMotion
from twin.process.force.learned import LearnedForceField
from twin.process.part.heightmap import SUBSTEPS
from twin.sim.compiled.isf_map import (
    ALPHA,
    COUNT,
    DIR_X,
    DIR_Y,
    HAS_LAST,
    LAST_X,
    LAST_Y,
    LAST_Z,
    Q_HEAD,
    RADIAL_RISE,
    RISE,
    SIDE,
    STATE_SLOTS,
    TF,
    TP,
    TRAVEL,
    TS,
    TW,
    TX,
    TY,
    TZ,
    IsfArrays,
    met_height,
    met_owner,
)
from twin.sim.compiled.learned import learned_terms


def isf_arrays(field: IsfForceField, capacity: int) -> IsfArrays | None:
    """Pack a reset `field` for a replay of `capacity` samples; None if it is not fresh (the loop starts flat)."""
    hm = field.map
    motion = field.state
    if not hm.is_fresh or motion.last_tip_m is not None or motion.direction != (0.0, 0.0):
        return None
    p = field.params
    ny, nx = hm.z_met_m.shape
    prm = np.array([
        field.base_fz_n, p.wall_angle_max_deg, p.build_up_m, p.step_min_m, p.k_unload_n_per_m, p.mu_eff,
        p.direction_length_m, isf_force.ALPHA_LENGTH_M, isf_force.WALL_BASELINE_M, float(isf_force.WALL_MAX_LAYERS),
        sliding.RELEASE_LENGTH_M, p.mu_radial, isf_force.WALL_RUN_MIN_M, p.tool_radius_m,
        *_learned_prm(field),
    ])
    if prm.shape[0] != RADIAL_RISE + 1:
        raise RuntimeError(f"the ISF kernel's constants hold {prm.shape[0]} slots; μ_ρ's slot is {RADIAL_RISE}")
    state = np.zeros(STATE_SLOTS)
    state[ALPHA] = motion.wall_angle_deg
    state[SIDE] = motion.wall_side
    return IsfArrays(
        z_met=hm.z_met_m, owner=hm.owner_met, templates=hm.templates(), track=np.zeros((max(capacity, 1), 7)),
        grid=np.array([hm.x0, hm.y0, hm.h, nx, ny, hm.half_window, hm.lag, SUBSTEPS]), prm=prm, state=state,
    )


def _learned_prm(field: IsfForceField) -> list[float]:
    """The learned terms' slots of `prm` (`twin.process.force.learned`): a flag, the membrane weights, reach and
    cap, the formed-state weights, the contact width, the reference wall angle and μ_ρ (at `RADIAL_RISE`)."""
    if isinstance(field, LearnedForceField):
        w = field.weights.as_array()
        return [1.0, *w[:4], learned_force.REACH, learned_force.CAP, *w[4:], learned_force.CONTACT_WIDTH_M,
                learned_force.ALPHA_REF_DEG, field.radial_rise]
    return [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, *[0.0] * (len(learned_force.WEIGHT_KEYS) - 4),
            learned_force.CONTACT_WIDTH_M,
            learned_force.ALPHA_REF_DEG, 0.0]


def idle_isf_arrays() -> IsfArrays:
    """A placeholder of the right types for a replay on the table field (never read)."""
    return IsfArrays(np.zeros((2, 2)), np.full((2, 2), -1, dtype=np.int64), np.zeros((1, 1, 1, 1)), np.zeros((1, 7)),
                     np.zeros(8), np.zeros(RADIAL_RISE + 1), np.zeros(STATE_SLOTS))


def write_back(field: IsfForceField, arrays: IsfArrays) -> None:
    """Hand the state a compiled replay left in `arrays` back to `field` and its map."""
    st, track = arrays.state, arrays.track
    count = int(st[COUNT])
    field.map.restore(track[:count, : TS + 1], float(st[TRAVEL]), int(st[Q_HEAD]))
    last = (float(st[LAST_X]), float(st[LAST_Y]), float(st[LAST_Z])) if st[HAS_LAST] else None
    step = math.dist(tuple(track[count - 2, :3]), tuple(track[count - 1, :3])) if count >= 2 else 0.0
    field.restore(IsfMotion((float(st[DIR_X]), float(st[DIR_Y])), last, float(st[ALPHA]), step,
                            float(st[SIDE])))


@njit(cache=True)
def _scallop(radius: float, dz: float, sin_a: float) -> tuple:
    """`twin.process.force.aerens.scallop_height_m` and its derivative in the engagement, as `IsfForceField._fz_of`."""
    half = 0.5 * dz / sin_a if sin_a > 0.0 else math.inf
    if half < 0.999 * radius:
        root = math.sqrt(radius * radius - half * half)
        return radius - root, half / root * 0.5 / sin_a
    return radius, 0.0


@njit(cache=True)
def _fz(M: IsfArrays, x: float, y: float, z: float) -> tuple:
    """`IsfForceField._fz`: (Fz, dFz/dx, dFz/dy, dFz/dz) [N, N/m]."""
    base, D0, dmin, k_unload, radius = M.prm[0], M.prm[2], M.prm[3], M.prm[4], M.prm[13]
    s, sx, sy = met_height(M, x, y)
    dh = s - z
    alpha = M.state[ALPHA]
    depth = max(-z, 0.0)
    e = math.exp(-depth / D0)
    build = 1.0 - e
    dbuild_dz = -e / D0 if z < 0.0 else 0.0
    g = base * alpha * math.cos(math.radians(alpha))
    sin_a = math.sin(math.radians(alpha))
    if dh > dmin:
        h, dh_ddz = _scallop(radius, dh, sin_a)
        f0 = g * (1e3 * h) ** 0.09
        lin, dlin_ddh = f0 * build, 0.09 * f0 * build / h * dh_ddz
    elif dh >= 0.0:
        f0 = g * (1e3 * _scallop(radius, dmin, sin_a)[0]) ** 0.09
        lin, dlin_ddh = f0 * build, 0.0
    else:
        f0 = g * (1e3 * _scallop(radius, dmin, sin_a)[0]) ** 0.09
        lin, dlin_ddh = f0 * build + k_unload * dh, k_unload
    gx, gy, gz = dlin_ddh * sx, dlin_ddh * sy, -dlin_ddh + f0 * dbuild_dz
    if M.prm[14] != 0.0:
        lin, gx, gy, gz = learned_terms(M, x, y, z, lin, gx, gy, gz)
    w = 5.0  # the softplus width of `twin.process.force.isf`
    if lin > 30.0 * w:
        fz, slope = lin, 1.0
    else:
        ex = math.exp(lin / w)
        fz, slope = w * math.log1p(ex), ex / (1.0 + ex)
    return fz, slope * gx, slope * gy, slope * gz


@njit(cache=True)
def _travel(M: IsfArrays, x: float, y: float) -> tuple:
    """`IsfForceField._travel` (`twin.process.force.sliding.sliding_direction`): (vx, vy, has a Jacobian, ∂vx/∂x,
    ∂vx/∂y, ∂vy/∂x, ∂vy/∂y)."""
    st = M.state
    if st[HAS_LAST] == 0.0:
        return st[DIR_X], st[DIR_Y], False, 0.0, 0.0, 0.0, 0.0
    dx, dy = x - st[LAST_X], y - st[LAST_Y]
    length = math.hypot(dx, dy)
    if length < 1e-9:
        return st[DIR_X], st[DIR_Y], False, 0.0, 0.0, 0.0, 0.0
    ex, ey = dx / length, dy / length
    qx, qy = st[DIR_X], st[DIR_Y]
    c = qx * ex + qy * ey
    pxx, pxy, pyy = 1.0 - ex * ex, -ex * ey, 1.0 - ey * ey
    dqxx = dqxy = dqyx = dqyy = 0.0
    if c < 0.0:
        Lr = M.prm[10]
        wr = math.exp(-length / Lr)
        r = 1.0 - wr
        qx, qy = qx - r * c * ex, qy - r * c * ey
        a, b, k = c * wr / Lr, r / length, r * c / length
        gx, gy = st[DIR_X] - c * ex, st[DIR_Y] - c * ey
        dqxx = -(a * ex * ex + b * ex * gx + k * pxx)
        dqxy = -(a * ex * ey + b * ex * gy + k * pxy)
        dqyx = -(a * ey * ex + b * ey * gx + k * pxy)
        dqyy = -(a * ey * ey + b * ey * gy + k * pyy)
    L = M.prm[6]
    w = math.exp(-length / L)
    vx, vy = w * qx + (1.0 - w) * ex, w * qy + (1.0 - w) * ey
    dw = -w / L
    g = (1.0 - w) / length
    return (vx, vy, True, (qx - ex) * dw * ex + w * dqxx + g * pxx, (qx - ex) * dw * ey + w * dqxy + g * pxy,
            (qy - ey) * dw * ex + w * dqyx + g * pxy, (qy - ey) * dw * ey + w * dqyy + g * pyy)


@njit(cache=True)
def isf_eval(M: IsfArrays, x: float, y: float, z: float, f: np.ndarray, S: np.ndarray) -> tuple:
    """`IsfForceField.force_and_stiffness`: the force into `f` (3,) [N] and ∂f/∂p into `S` (3, 3) [N/m].

    Returns:
        The sliding direction (vx, vy) at the tip [-] (what `isf_advance_from` takes).
    """
    fz, gx, gy, gz = _fz(M, x, y, z)
    vx, vy, has_jac, j00, j01, j10, j11 = _travel(M, x, y)
    # `IsfForceField._in_plane`: A = [[-μ_t, σμ_r], [-σμ_r, -μ_t]], μ_r + μ_ρ Σu_s for the learned model's
    mu, mr = M.prm[5], (M.prm[11] + M.prm[RADIAL_RISE] * M.state[RISE]) * M.state[SIDE]
    axx, axy, ayx, ayy = -mu, mr, -mr, -mu
    ax, ay = axx * vx + axy * vy, ayx * vx + ayy * vy
    S[0, 0], S[0, 1], S[0, 2] = ax * gx, ax * gy, ax * gz
    S[1, 0], S[1, 1], S[1, 2] = ay * gx, ay * gy, ay * gz
    S[2, 0], S[2, 1], S[2, 2] = gx, gy, gz
    if has_jac:
        S[0, 0] += fz * (axx * j00 + axy * j10)
        S[0, 1] += fz * (axx * j01 + axy * j11)
        S[1, 0] += fz * (ayx * j00 + ayy * j10)
        S[1, 1] += fz * (ayx * j01 + ayy * j11)
    f[0], f[1], f[2] = ax * fz, ay * fz, fz
    return vx, vy


@njit(cache=True)
def _round_half_even(value: float) -> int:
    """Python's `round` of a float: to the nearest integer, ties to even."""
    low = math.floor(value)
    rest = value - low
    if rest > 0.5 or (rest == 0.5 and low % 2 != 0):
        return int(low) + 1
    return int(low)


@njit(cache=True)
def _lower_commit(M: IsfArrays, index: int) -> None:
    """`_lower` of commit `index`'s sphere into the met surface (its snapped template, clipped at the edge)."""
    t = M.track[index]
    x0, y0, h, nx, ny, m, sub = M.grid[0], M.grid[1], M.grid[2], int(M.grid[3]), int(M.grid[4]), int(M.grid[5]), M.grid[7]
    u, v = (t[TX] - x0) / h, (t[TY] - y0) / h
    iu, iv = math.floor(u), math.floor(v)
    bu, bv = _round_half_even((u - iu) * sub), _round_half_even((v - iv) * sub)
    ix0, iy0 = iu - m, iv - m
    tpl, tz = M.templates[bu, bv], t[TZ]
    c0, c1 = max(ix0, 0), min(ix0 + 2 * m + 2, nx)
    for r in range(max(iy0, 0), min(iy0 + 2 * m + 2, ny)):
        _lower_row(M.z_met[r, c0:c1], M.owner[r, c0:c1], tpl[r - iy0, c0 - ix0 : c1 - ix0], tz, index)


@njit(cache=True, inline="always")
def _lower_row(z: np.ndarray, owner: np.ndarray, template: np.ndarray, tz: float, index: int) -> None:
    """One row of `_lower_commit`: z <- min(z, template + tz), owner `index` where lowered (branch-free, from 0:
    the compiler vectorizes it)."""
    for k in range(z.shape[0]):
        cap = template[k] + tz
        old = z[k]
        lower = cap < old
        z[k] = cap if lower else old
        owner[k] = index if lower else owner[k]


@njit(cache=True)
def _has_patch(M: IsfArrays, x: float, y: float) -> bool:
    x0, y0, h, nx, ny, m = M.grid[0], M.grid[1], M.grid[2], int(M.grid[3]), int(M.grid[4]), int(M.grid[5])
    ix0, iy0 = math.floor((x - x0) / h) - m, math.floor((y - y0) / h) - m
    return min(ix0 + 2 * m + 2, nx) > max(ix0, 0) and min(iy0 + 2 * m + 2, ny) > max(iy0, 0)


@njit(cache=True)
def _wall_angle(M: IsfArrays, owner: int, x: float, y: float, z: float) -> tuple:
    """`IsfForceField._wall_angle`: ([deg], nx, ny); NaN where nothing is formed."""
    if owner < 0:
        return math.nan, 0.0, 0.0
    q = M.track[owner]
    for _ in range(int(M.prm[9])):
        if q[TZ] - z >= M.prm[8] or q[TP] < 0:
            break
        q = M.track[int(q[TP])]
    dx, dy = q[TX] - x, q[TY] - y
    run = math.hypot(dx, dy)
    alpha = min(math.degrees(math.atan2(max(q[TZ] - z, 0.0), run)), M.prm[1])
    if run < M.prm[12]:
        return alpha, 0.0, 0.0
    return alpha, dx / run, dy / run


@njit(cache=True)
def isf_advance(M: IsfArrays, x: float, y: float, z: float) -> None:
    """`IsfForceField.advance` (f_z the model's at the tip) with `HeightMap.commit`."""
    vx, vy = _travel(M, x, y)[:2]
    isf_advance_from(M, x, y, z, _fz(M, x, y, z)[0], vx, vy)


@njit(cache=True)
def isf_advance_from(M: IsfArrays, x: float, y: float, z: float, f_z: float, vx: float, vy: float) -> None:
    """`isf_advance` with the model's f_z [N] and sliding direction (vx, vy) at the tip, from an `isf_eval` there
    in the same state."""
    st = M.state
    st[DIR_X], st[DIR_Y] = vx, vy
    step = 0.0
    if st[HAS_LAST] != 0.0:
        step = math.sqrt((x - st[LAST_X]) ** 2 + (y - st[LAST_Y]) ** 2 + (z - st[LAST_Z]) ** 2)
    st[HAS_LAST], st[LAST_X], st[LAST_Y], st[LAST_Z] = 1.0, x, y, z
    owner = met_owner(M, x, y)
    alpha, nx, ny = _wall_angle(M, owner, x, y, z)
    if not math.isnan(alpha):
        speed = math.hypot(vx, vy)
        side = (vx * ny - vy * nx) / speed if speed > 0.0 else 0.0
        k = 1.0
        if step > 0.0 and M.prm[7] > 0.0:
            k = 1.0 - math.exp(-step / M.prm[7])
        st[ALPHA] += k * (alpha - st[ALPHA])
        st[SIDE] += k * (side - st[SIDE])
    # HeightMap.commit: travel, the track, the pending commits that have left the lag
    index = int(st[COUNT])
    if index > 0:
        last = M.track[index - 1]
        st[TRAVEL] += math.sqrt((x - last[TX]) ** 2 + (y - last[TY]) ** 2 + (z - last[TZ]) ** 2)
    row = M.track[index]
    row[TX], row[TY], row[TZ], row[TF], row[TP], row[TS] = x, y, z, f_z, owner, st[TRAVEL]
    row[TW] = 1.0 if _has_patch(M, x, y) else 0.0
    st[COUNT] = index + 1
    head = int(st[Q_HEAD])
    while head <= index and st[TRAVEL] - M.track[head, TS] >= M.grid[6]:
        if M.track[head, TW] != 0.0:
            _lower_commit(M, head)
        head += 1
    st[Q_HEAD] = head
