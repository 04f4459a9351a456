# mypy: disable-error-code="arg-type, assignment, return-value"
# (numba kernels: the numpy scalars they pass, typed non-literal on purpose, are not the annotated builtins)
"""The sheet's force and stiffness at a trial tip in the compiled loop, on the clamping frame that gives.

`sheet_at` is the sheet itself at (x, y, z): the ISF model (`kind` 1) or the table field sliding or in the stick
band. `sheet` puts it on a frame of compliance `frame` [m/N] along the sheet's normal, as
`twin.sim.giving_frame.GivingFrame` does in Python (same Newton on the give delta = frame f_z at z + delta, same
gradient); `frame_give` is that give at an equilibrium, where the loop reads the force and advances the sheet.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from twin.sim.compiled.field import FieldArrays, field_eval
from twin.sim.compiled.isf import IsfArrays, isf_eval

#: Newton on the frame's give, as `twin.sim.giving_frame` (ITERATIONS, TOLERANCE_M).
FRAME_ITERATIONS = 30
FRAME_TOLERANCE_M = 1e-10


@njit(cache=True)
def sheet_at(
    F: FieldArrays, M: IsfArrays, kind: int, cur: int, mode: int, slip: float, x_prev: float, gain: float,
    x: float, y: float, z: float, pass_index: int, direction: int, f: np.ndarray, S: np.ndarray,
) -> float:
    """The sheet's force `f` and ∂f/∂p `S` at the tip (x, y, z): the ISF model (`kind` 1), or the table field
    sliding along `direction` (mode 0) or in the stick band (mode 1).

    Returns:
        The sticking part of dFx/dx [N/m] (0 when sliding).
    """
    if kind == 1:
        isf_eval(M, x, y, z, f, S)
        return 0.0
    if mode == 0:
        fx, fz, fx_x, fx_z, fz_x, fz_z = field_eval(F, cur, x, z, pass_index, direction)
        stick = 0.0
    else:
        fx, fz, fx_x, fx_z, fz_x, fz_z = field_eval(F, cur, x, z, pass_index, np.int64(1))
        s = slip + gain * (x - x_prev)
        stick = fx * gain
        fx, fx_x, fx_z = s * fx, s * fx_x + stick, s * fx_z
    f[0], f[1], f[2] = fx, 0.0, fz
    S[:] = 0.0
    S[0, 0], S[0, 2], S[2, 0], S[2, 2] = fx_x, fx_z, fz_x, fz_z
    return stick


@njit(cache=True)
def frame_give(
    F: FieldArrays, M: IsfArrays, kind: int, cur: int, mode: int, slip: float, x_prev: float, gain: float,
    frame: float, p: np.ndarray, pass_index: int, direction: int, f: np.ndarray, S: np.ndarray,
) -> float:
    """The frame's give delta [m] at the tip `p` (0 without a frame), `f` and `S` left at z + delta."""
    delta = 0.0
    if frame > 0.0:
        for _ in range(FRAME_ITERATIONS):
            sheet_at(F, M, kind, cur, mode, slip, x_prev, gain, p[0], p[1], p[2] + delta, pass_index, direction, f, S)
            step = (delta - frame * f[2]) / (1.0 - frame * min(S[2, 2], 0.0))
            delta -= step
            if abs(step) < FRAME_TOLERANCE_M:
                break
    return delta


@njit(cache=True)
def sheet(
    F: FieldArrays, M: IsfArrays, kind: int, cur: int, mode: int, slip: float, x_prev: float, gain: float,
    frame: float, p: np.ndarray, pass_index: int, direction: int, f: np.ndarray, S: np.ndarray,
) -> float:
    """`sheet_at` the tip `p` on the frame: the force at z + delta and its gradient through the give,
    S + S e_z (d delta/dp)^T, d delta/dp = frame S[2, :] / (1 - frame S_zz). Returns the sticking part of dFx/dx."""
    delta = frame_give(F, M, kind, cur, mode, slip, x_prev, gain, frame, p, pass_index, direction, f, S)
    stick = sheet_at(F, M, kind, cur, mode, slip, x_prev, gain, p[0], p[1], p[2] + delta, pass_index, direction, f, S)
    if frame > 0.0:
        den = 1.0 - frame * min(S[2, 2], 0.0)
        d0, d1, d2 = frame * S[2, 0] / den, frame * S[2, 1] / den, frame * S[2, 2] / den
        for r in range(3):
            col = S[r, 2]
            S[r, 0] += col * d0
            S[r, 1] += col * d1
            S[r, 2] += col * d2
    return stick
