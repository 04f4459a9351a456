"""Families acting on the tracker's and the profile scanner's data: drift, registration, springback."""

from __future__ import annotations

import numpy as np

from twin.analysis.discrepancy.context import Context
from twin.analysis.discrepancy.families.base import Delta, Family, register
from twin.sim.effects import TRACKER_DRIFT_DIRECTION


@register
class TrackerDrift(Family):
    """The tracker's reading drifts linearly with time, in any direction."""

    name = "tracker_drift"
    parameters = ("rate_x_mm_per_s", "rate_y_mm_per_s", "rate_z_mm_per_s")
    neutral = (0.0, 0.0, 0.0)
    bounds = ((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))
    scale = (0.005, 0.005, 0.005)
    description = "linear drift of the tracker reading with time"
    effect = "tracker_drift"
    acts_on = ("position",)

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Position change (t - t0) x rate."""
        t = ctx.run.tracker.t_s - ctx.t_cmd[0]
        return Delta(position=1e-3 * np.outer(t, theta))

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        """`tracker_drift` [mm/s] when the rate is along the effect's drift direction (within 3 sigma)."""
        rate = float(theta @ TRACKER_DRIFT_DIRECTION)
        off = theta - rate * TRACKER_DRIFT_DIRECTION
        if covariance is None or np.linalg.norm(off) > 3.0 * np.sqrt(np.trace(covariance)):
            return None
        return rate


@register
class TrackerRegistration(Family):
    """The tracker frame is registered to the sheet with a small rotation and translation error."""

    name = "tracker_registration"
    parameters = ("rot_x_mrad", "rot_y_mrad", "rot_z_mrad", "shift_x_mm", "shift_y_mm", "shift_z_mm")
    neutral = (0.0,) * 6
    bounds = ((-50.0,) * 3 + (-20.0,) * 3, (50.0,) * 3 + (20.0,) * 3)
    scale = (0.1,) * 3 + (0.01,) * 3
    description = "small rotation and translation of the tracker frame"
    acts_on = ("position",)

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Position change w x (p - centroid) + shift, rotation about the centroid of the predicted path."""
        p = ctx.pred["position"]
        lever = p - p.mean(axis=0)
        return Delta(position=1e-3 * np.cross(theta[:3], lever) + 1e-3 * theta[3:])


@register
class SheetSpringback(Family):
    """The part recovers a fraction of its formed depth after unclamping."""

    name = "sheet_springback"
    parameters = ("springback_ratio",)
    neutral = (0.0,)
    bounds = ((-0.5,), (0.9,))
    scale = (0.01,)
    description = "fraction of the formed depth recovered after unclamping"
    needs_profile = True
    acts_on = ("profile",)
    effect = "sheet_springback"

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Profile change -ratio x predicted profile."""
        return Delta(profile=-theta[0] * ctx.pred["profile"])

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        """`sheet_springback` (an increment, composed with the twin's own by the search)."""
        del covariance
        return float(theta[0]) if 0.0 <= theta[0] < 1.0 else None

