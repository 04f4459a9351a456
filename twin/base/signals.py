"""Sampled signals: interpolation of many channels at once, a path's arc length, and the sample clock of a stream."""

from __future__ import annotations

import numpy as np


def interp_rows(query: np.ndarray, sample: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of every column of `values` at `query` (held at the ends, like `np.interp`).

    Args:
        query: Where to evaluate (times [s] or arc lengths [m]), shape (m,).
        sample: Increasing sample points of `values`, same unit, shape (n,).
        values: Sampled channels, shape (n, k).

    Returns:
        The channels at `query`, shape (m, k).
    """
    values = np.asarray(values, dtype=float)
    return np.column_stack([np.interp(query, sample, values[:, j]) for j in range(values.shape[1])])


def arc_length(p: np.ndarray) -> np.ndarray:
    """The length travelled along a polyline up to each of its points, from 0 [its unit], shape (n,)."""
    return np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(np.asarray(p, dtype=float), axis=0), axis=1))]


def uniform_times(t_end_s: float, rate_hz: float) -> np.ndarray:
    """Sample times 0, 1/rate, ... up to `t_end_s` (inclusive within 1e-9 s) [s]."""
    n = int(np.floor(t_end_s * rate_hz + 1e-9)) + 1
    return np.arange(n) / rate_hz
