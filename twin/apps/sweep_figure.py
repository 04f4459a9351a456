"""The figure of a Monte Carlo sweep (`twin.apps.sweep`): residual histograms and the residual against force scale."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.apps.sweep import SweepResult


def sweep_figure(result: SweepResult, path: str | Path) -> Path:
    """Histograms of the RMS and largest residual per draw, and the RMS against the force scale [mm]."""
    import matplotlib.pyplot as plt

    from twin.viz.style import save_figure  # viz runs before apps: an allowed import

    fig, axes = plt.subplots(1, 3, figsize=(13.0, 4.0))
    bins = max(10, min(60, len(result.rms_m) // 10))
    for ax, values, label in ((axes[0], result.rms_m, "RMS residual [mm]"),
                              (axes[1], result.max_m, "largest residual [mm]")):
        ax.hist(values * 1e3, bins=bins, color="tab:blue", alpha=0.8)
        ax.axvline(float(np.median(values)) * 1e3, color="black", lw=1, label="median")
        ax.set_xlabel(label)
        ax.set_ylabel("draws [-]")
    axes[0].axvline(result.nominal_rms_m * 1e3, color="tab:green", lw=1, ls="--", label="nominal model")
    axes[0].legend(fontsize=8)
    axes[2].scatter(result.parameters[:, 14], result.rms_m * 1e3, s=6, alpha=0.6)
    axes[2].set_xlabel("force scale [-]")
    axes[2].set_ylabel("RMS residual [mm]")
    fig.suptitle(f"compensated groove over {len(result.rms_m)} draws of the model's uncertainty "
                 f"({result.uncertainty.source})", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)
