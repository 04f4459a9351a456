"""Scratch space and the small dense solve of the compiled replay loop (`twin.sim.compiled.loop`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit


class Work(NamedTuple):
    """Scratch arrays of one replay (allocated once, reused by every Newton iteration)."""

    p: np.ndarray  # (3,)
    g: np.ndarray  # (nv,)
    f: np.ndarray  # (3,)
    r: np.ndarray  # (nv,)
    h: np.ndarray  # (nv, nv)
    dq: np.ndarray  # (nv,)
    jtf: np.ndarray  # (nv,)
    sj: np.ndarray  # (3, nv)
    base: np.ndarray  # (nv,)
    free: np.ndarray  # (nv,)
    demand: np.ndarray  # (nv,)
    stuck: np.ndarray  # (nv,) bool
    tau_fr: np.ndarray  # (nv,)


def work_arrays(nv: int) -> Work:
    """Scratch arrays for a model with `nv` dofs."""
    v, m = (lambda: np.zeros(nv)), (lambda rows: np.zeros((rows, nv)))
    return Work(np.zeros(3), v(), np.zeros(3), v(), m(nv), v(), v(), m(3), v(), v(), v(), np.zeros(nv, np.bool_), v())


@njit(cache=True)
def solve_linear(h: np.ndarray, r: np.ndarray, out: np.ndarray) -> bool:
    """out = h⁻¹ r by Gaussian elimination with partial pivoting (h and r are overwritten); False if singular."""
    n = r.shape[0]
    for col in range(n):
        piv = col
        best = abs(h[col, col])
        for row in range(col + 1, n):
            if abs(h[row, col]) > best:
                best, piv = abs(h[row, col]), row
        if best == 0.0:
            return False
        if piv != col:
            for s in range(n):
                h[col, s], h[piv, s] = h[piv, s], h[col, s]
            r[col], r[piv] = r[piv], r[col]
        inv = 1.0 / h[col, col]
        for row in range(col + 1, n):
            f = h[row, col] * inv
            if f != 0.0:
                for s in range(col, n):
                    h[row, s] -= f * h[col, s]
                r[row] -= f * r[col]
    for row in range(n - 1, -1, -1):
        acc = r[row]
        for s in range(row + 1, n):
            acc -= h[row, s] * out[s]
        out[row] = acc / h[row, row]
    return True


@njit(cache=True)
def tip_gains(jac: np.ndarray, k_diag: np.ndarray, stiffness: np.ndarray, out: np.ndarray) -> bool:
    """The tool tip's gain per sample, out = (I - J K⁻¹ Jᵀ S)⁻¹ (3×3 adjugate over determinant).

    Args:
        jac: Tool-tip Jacobians [m/rad], shape (n, 3, nv).
        k_diag: Joint springs [N·m/rad], shape (nv,).
        stiffness: The sheet's df/dp per sample [N/m], shape (n, 3, 3).
        out: Out: d p_tip / d p_cmd [-], shape (n, 3, 3).

    Returns:
        False if a matrix is singular (`out` then incomplete).
    """
    nv = k_diag.shape[0]
    inv_k = 1.0 / k_diag
    c = np.empty((3, 3))
    a = np.empty((3, 3))
    for i in range(jac.shape[0]):
        J, S = jac[i], stiffness[i]
        for r in range(3):
            for s in range(3):
                acc = 0.0
                for j in range(nv):
                    acc += J[r, j] * inv_k[j] * J[s, j]
                c[r, s] = acc
        for r in range(3):
            for s in range(3):
                a[r, s] = (1.0 if r == s else 0.0) - (c[r, 0] * S[0, s] + c[r, 1] * S[1, s] + c[r, 2] * S[2, s])
        c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
        c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
        c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
        det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
        if det == 0.0 or not np.isfinite(det):
            return False
        g, d = out[i], 1.0 / det
        g[0, 0], g[1, 0], g[2, 0] = c00 * d, c01 * d, c02 * d
        g[0, 1] = (a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]) * d
        g[1, 1] = (a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]) * d
        g[2, 1] = (a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]) * d
        g[0, 2] = (a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]) * d
        g[1, 2] = (a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]) * d
        g[2, 2] = (a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) * d
    return True
