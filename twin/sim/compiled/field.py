# mypy: disable-error-code="arg-type, assignment, return-value"
# (numba kernels: the numpy scalars they pass, typed non-literal on purpose, are not the annotated builtins)
"""The table sheet force field and the tool's sliding friction, in compiled code for the replay loop.

Mirrors, operation for operation, `twin.process.force.table.SheetForceField` (`_evaluate`, `force`, `advance`),
`twin.process.part.formed_profile.FormedProfile.commit` and the sliding state of
`twin.process.force.tool_friction.SlidingFriction`; `tests/test_compiled_replay.py` holds them together. The field's
profile arrays are the Python field's own, changed in place, so after a compiled replay the Python field holds
the same formed surface.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from twin.process.force.table import SOFTPLUS_N, SheetForceField


class FieldArrays(NamedTuple):
    """A `SheetForceField` as flat arrays: its per-pass tables (padded) and its formed profile (shared)."""

    fz: np.ndarray  # (passes, n_max) Fz_hist [N]
    ratio: np.ndarray  # (passes, n_max) Fx/Fz [-]
    plan: np.ndarray  # (passes, n_max) δ_plan (stateful) or z_plan [m]
    t_x0: np.ndarray  # (passes,) [m]
    t_dx: np.ndarray  # (passes,) [m]
    t_n: np.ndarray  # (passes,)
    t_dir: np.ndarray  # (passes,) +1 / -1
    formed: np.ndarray  # (N,) the field's formed profile [m] (the Python field's array)
    snapshot: np.ndarray  # (N,) its snapshot [m] (the Python field's array)
    grid: np.ndarray  # (x0, dx, n, radius) of the profile grid
    k: np.ndarray  # (k_load, k_unload, stateful, softplus width)


def field_arrays(field: SheetForceField) -> FieldArrays:
    """Pack `field` (tables copied, profile arrays shared)."""
    tables = field.pass_tables
    n_max = max(t.n for t in tables)

    def pad(name: str) -> np.ndarray:
        out = np.zeros((len(tables), n_max))
        for i, t in enumerate(tables):
            out[i, : t.n] = getattr(t, name)
        return out

    profile = field.profile
    return FieldArrays(
        fz=pad("fz"),
        ratio=pad("ratio"),
        plan=pad("delta_plan" if field.stateful else "z_plan"),
        t_x0=np.array([t.x0 for t in tables]),
        t_dx=np.array([t.dx for t in tables]),
        t_n=np.array([t.n for t in tables], dtype=np.int64),
        t_dir=np.array([t.direction for t in tables], dtype=np.int64),
        formed=profile.z_m,
        snapshot=profile.snapshot_m,
        grid=np.array([profile.x0, profile.dx, float(profile.n), profile.radius]),
        k=np.array([field.k_load, field.k_unload, 1.0 if field.stateful else 0.0, SOFTPLUS_N]),
    )


def idle_field_arrays() -> FieldArrays:
    """A placeholder of the right types for a replay on another field (never read)."""
    z = np.zeros((1, 2))
    one = np.ones(1)
    return FieldArrays(z, z, z, one, one, np.full(1, 2, dtype=np.int64), np.ones(1, dtype=np.int64), np.zeros(2),
                       np.zeros(2), np.array([0.0, 1.0, 2.0, 1.0]), np.array([1.0, 1.0, 1.0, 5.0]))


@njit(cache=True)
def _lerp_slope(table: np.ndarray, x0: float, dx: float, n: int, x: float) -> tuple[float, float]:
    u = (x - x0) / dx
    if u <= 0.0:
        return table[0], 0.0
    if u >= n - 1:
        return table[n - 1], 0.0
    i = int(u)
    f = u - i
    a, b = table[i], table[i + 1]
    return a * (1.0 - f) + b * f, (b - a) / dx


@njit(cache=True)
def field_eval(F: FieldArrays, current_pass: int, x: float, z: float, pass_index: int, direction: int) -> tuple:
    """(Fx, Fz, dFx/dx, dFx/dz, dFz/dx, dFz/dz) [N, N/m]: `SheetForceField._evaluate`."""
    t = pass_index - 1
    x0, dx, n = F.t_x0[t], F.t_dx[t], F.t_n[t]
    fz_h, dfz_h = _lerp_slope(F.fz[t], x0, dx, n, x)
    ratio, dratio = _lerp_slope(F.ratio[t], x0, dx, n, x)
    plan, dplan = _lerp_slope(F.plan[t], x0, dx, n, x)
    k_load, k_unload = F.k[0], F.k[1]
    if F.k[2] != 0.0:
        ref = F.snapshot if pass_index == current_pass else F.formed
        z_ref, dz_ref = _lerp_slope(ref, F.grid[0], F.grid[1], int(F.grid[2]), x)
        delta = z_ref - z
        if delta > 0.0:
            k = k_load
            lin, dlin_dx = fz_h + k * (delta - plan), dfz_h + k * (dz_ref - dplan)
        else:
            k = k_unload
            lin = fz_h - k_load * plan + k * delta
            dlin_dx = dfz_h - k_load * dplan + k * dz_ref
    else:
        err = plan - z
        k = k_load if err > 0.0 else k_unload
        lin, dlin_dx = fz_h + k * err, dfz_h + k * dplan
    w = F.k[3]
    if lin > 30.0 * w:
        fz, slope = lin, 1.0
    else:
        e = math.exp(lin / w)
        fz, slope = w * math.log1p(e), e / (1.0 + e)
    sign = 1.0 if direction * F.t_dir[t] > 0 else -1.0
    dfz_dx, dfz_dz = slope * dlin_dx, -slope * k
    return (sign * ratio * fz, fz, sign * (dratio * fz + ratio * dfz_dx), sign * ratio * dfz_dz, dfz_dx, dfz_dz)


@njit(cache=True)
def field_force(F: FieldArrays, current_pass: int, x: float, z: float, pass_index: int, direction: int) -> tuple:
    """(Fx, Fz) [N]: `SheetForceField.force`."""
    fx, fz, _, _, _, _ = field_eval(F, current_pass, x, z, pass_index, direction)
    return fx, fz


@njit(cache=True)
def field_advance(F: FieldArrays, current_pass: int, x: float, z: float, pass_index: int) -> int:
    """`SheetForceField.advance` with a given pass (never before the current one); returns the current pass."""
    if pass_index != current_pass:
        for i in range(F.formed.shape[0]):  # element by element: a slice copy compiles its shape check's message
            F.snapshot[i] = F.formed[i]
        current_pass = pass_index
    x0, dx, n, r = F.grid[0], F.grid[1], int(F.grid[2]), F.grid[3]
    i0 = max(0, math.ceil((x - r - x0) / dx))
    i1 = min(n, math.floor((x + r - x0) / dx) + 1)
    for i in range(i0, i1):
        u = (x0 + dx * i) - x
        cap = z + r - math.sqrt(max(r * r - u * u, 0.0))
        if cap < F.formed[i]:
            F.formed[i] = cap
    return current_pass
