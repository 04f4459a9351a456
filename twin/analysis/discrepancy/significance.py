"""Significance of residuals: reduced chi-square per stream against the noise, excess over noise, contradiction."""

from __future__ import annotations

import numpy as np

CHI2_MARGIN = 0.15  # noise estimates are good to a few per cent; below this the residual is noise


def reduced_chi2(streams: dict[str, np.ndarray], sigma: dict[str, float]) -> dict[str, float]:
    """Reduced chi-square of each residual stream against its noise sigma."""
    return {name: float(np.mean((values / sigma[name]) ** 2)) for name, values in streams.items()}


def is_significant(chi2: dict[str, float], counts: dict[str, int]) -> bool:
    """Whether any stream's residual is above what its noise explains (margin plus five standard errors)."""
    return any(chi2[name] > 1.0 + CHI2_MARGIN + 5.0 * np.sqrt(2.0 / max(counts[name], 1)) for name in chi2)


def is_contradicted(chi2_now: dict[str, float], chi2_new: dict[str, float], counts: dict[str, int]) -> bool:
    """Whether a new fit makes any stream's residual significantly worse than it is now.

    A stream is worse when its reduced chi-square rises by more than CHI2_MARGIN (relative, and not below
    the significance level of a noise-only stream) plus five standard errors.
    """
    return any(
        chi2_new[name]
        > (1.0 + CHI2_MARGIN) * max(chi2_now[name], 1.0 + CHI2_MARGIN)
        + 5.0 * np.sqrt(2.0 / max(counts[name], 1))
        for name in chi2_new
    )


def excess_over_noise(r: np.ndarray, sizes: list[int]) -> float:
    """Sum over streams of the normalised squared residual above its noise-only expectation, each >= 0.

    Per stream, so that a stream whose noise was estimated a little high (reduced chi-square below 1)
    cannot hide the excess of another.

    Args:
        r: Stacked normalised residual (`ResidualModel.vector`).
        sizes: Length of each stream's part of `r`, in order.
    """
    parts = np.split(r, np.cumsum(sizes)[:-1])
    return float(sum(max(float(part @ part) - part.size, 0.0) for part in parts))


def split_streams(r: np.ndarray, sizes: dict[str, int]) -> dict[str, np.ndarray]:
    """The stacked vector cut back into its streams (in the order of `sizes`)."""
    parts = np.split(r, np.cumsum(list(sizes.values()))[:-1])
    return dict(zip(sizes, parts, strict=True))
