"""Sampled signals: interpolation of many channels at once."""

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
