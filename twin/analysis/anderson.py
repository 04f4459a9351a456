"""Anderson acceleration of a fixed-point iteration x <- x + f(x) (Walker & Ni, SIAM J. Numer. Anal. 49, 2011).

Each iteration of the twin compensation takes a local step f(x) (a Newton step per sample) that ignores how a
sample's command moves later samples' tips: pressing deeper at one level forms the surface the next level
meets. The iteration then shrinks the residual by a roughly constant factor per simulation. Anderson
acceleration keeps the last `memory` iterates and steps and mixes them (a least-squares fit of the latest step
by the step differences), so the coupling each simulation revealed is used in the next command: on a linear map
it is GMRES applied to the fixed point.
"""

from __future__ import annotations

import numpy as np

from twin.errors import InputError


class Anderson:
    """Type-II Anderson mixing with a sliding memory, unit damping.

    Attributes:
        memory: Number of earlier iterates the mixing uses (0: the plain iteration x + f).
    """

    def __init__(self, memory: int) -> None:
        if memory < 0:
            raise InputError(f"Anderson memory = {memory!r}: expected >= 0")
        self.memory = memory
        self._x: list[np.ndarray] = []
        self._f: list[np.ndarray] = []

    def clear(self) -> None:
        """Forget the earlier iterates (after a step that made the residual worse)."""
        self._x, self._f = [], []

    def next(self, x: np.ndarray, f: np.ndarray) -> np.ndarray:
        """The next iterate from the current one `x` and its step `f` (same shape, any).

        Returns:
            x + f - (ΔX + ΔF) γ, with γ the least-squares solution of ΔF γ ≈ f over the kept differences.
        """
        shape = np.shape(x)
        xv, fv = np.ravel(x).astype(float), np.ravel(f).astype(float)
        self._x = [*self._x, xv][-(self.memory + 1):]
        self._f = [*self._f, fv][-(self.memory + 1):]
        if len(self._x) < 2:
            return (xv + fv).reshape(shape)
        d_x = np.diff(np.stack(self._x, axis=1), axis=1)
        d_f = np.diff(np.stack(self._f, axis=1), axis=1)
        gamma, *_ = np.linalg.lstsq(d_f, fv, rcond=None)
        return (xv + fv - (d_x + d_f) @ gamma).reshape(shape)
