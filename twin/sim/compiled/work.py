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
