"""Families acting on the tracker's and the profile scanner's data: drift, registration, the tracker's clock,
springback."""

from __future__ import annotations

import numpy as np

from twin.analysis.discrepancy.context import Context
from twin.analysis.discrepancy.families.base import Delta, Family, register
from twin.base.signals import interp_rows
from twin.sim.effects import TRACKER_DRIFT_DIRECTION

CLOCK_SCAN_POINTS = 81  # coarse scan of the tracker clock's offset over +-0.2 s (5 ms apart)
CLOCK_SCAN_S = 0.2


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

    def to_instruments(self, theta: np.ndarray, ctx: Context) -> dict[str, np.ndarray] | None:
        """The drift in any direction [mm/s] (where it is not along the effect's: `to_effect`)."""
        return {"tracker_drift_mm_per_s": np.asarray(theta, dtype=float)}


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

    def to_instruments(self, theta: np.ndarray, ctx: Context) -> dict[str, np.ndarray] | None:
        """The rotation [mrad] and the shift [mm], moved from the path's centroid c to the sheet origin (where the
        instruments turn the tracker, so that it carries to another part): s' = s - w x c."""
        centroid_m = ctx.pred["position"].mean(axis=0)
        return {"tracker_rotation_mrad": np.asarray(theta[:3], dtype=float),
                "tracker_shift_mm": np.asarray(theta[3:], dtype=float) - np.cross(theta[:3], centroid_m)}


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



@register
class TrackerClock(Family):
    """The tracker's clock is offset from the controller's and runs at a slightly different rate: a sample
    stamped t was taken at t - offset - rate (t - t0), so the reading lags (or leads) the tool along the path."""

    name = "tracker_clock"
    parameters = ("offset_s", "rate_ratio")
    neutral = (0.0, 0.0)
    bounds = ((-1.0, -0.01), (1.0, 0.01))
    scale = (0.002, 1e-4)
    description = "tracker clock offset from the controller's plus a rate error"
    acts_on = ("position",)
    linear = False

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Position change tip(t - offset - rate (t - t0)) - tip(t) along the simulated path."""
        t = ctx.run.tracker.t_s
        t0 = ctx.t_cmd[0]
        taken = np.clip(t - theta[0] - theta[1] * (t - t0), ctx.sim.t_s[0], ctx.sim.t_s[-1])
        return Delta(position=interp_rows(taken, ctx.sim.t_s, ctx.sim.p_sheet_m)
                     - interp_rows(np.clip(t, ctx.sim.t_s[0], ctx.sim.t_s[-1]), ctx.sim.t_s, ctx.sim.p_sheet_m))

    def start(self, ctx: Context, residual: dict[str, np.ndarray]) -> np.ndarray:
        """The best offset of a coarse scan over +-CLOCK_SCAN_S (rate 0), or neutral."""
        target = residual["position"]
        best, best_sse = np.array(self.neutral, dtype=float), float(np.sum(target**2))
        for tau in np.linspace(-CLOCK_SCAN_S, CLOCK_SCAN_S, CLOCK_SCAN_POINTS):
            theta = np.array([tau, 0.0])
            change = self.delta(ctx, theta).position
            assert change is not None
            sse = float(np.sum((target - change) ** 2))
            if sse < best_sse:
                best, best_sse = theta, sse
        return best

    def to_instruments(self, theta: np.ndarray, ctx: Context) -> dict[str, np.ndarray] | None:
        """The tracker clock's offset [s] and rate error [-]."""
        return {"tracker_time_offset_s": np.array([theta[0]]), "tracker_time_rate": np.array([theta[1]])}
