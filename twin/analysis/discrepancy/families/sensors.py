"""Families acting on the force sensor's data: bias, gain, cross-talk between axes, clock offset and rate skew."""

from __future__ import annotations

import numpy as np

from twin.analysis.discrepancy.context import Context
from twin.analysis.discrepancy.families.base import Delta, Family, register

TIME_SCAN_POINTS = 161  # coarse scan of the clock offset over its bounds (a 0.3 s offset is far from 0)
SKEW_SCAN_POINTS = 101  # scans of the rate error: over its bounds (1e-3 apart), then within one step of the best


@register
class ForceSensorBias(Family):
    """A constant offset of each force axis (a zeroing error of the sensor)."""

    name = "force_sensor_bias"
    parameters = ("bias_x_n", "bias_y_n", "bias_z_n")
    neutral = (0.0, 0.0, 0.0)
    bounds = ((-1e4, -1e4, -1e4), (1e4, 1e4, 1e4))
    scale = (10.0, 10.0, 10.0)
    description = "constant offset of the force sensor on each axis"
    needs_forces = True
    acts_on = ("force",)

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Every force sample shifted by theta [N]."""
        return Delta(force=np.broadcast_to(theta, ctx.pred["force"].shape).copy())

    def to_instruments(self, theta: np.ndarray, ctx: Context) -> dict[str, np.ndarray] | None:
        """The F/T bias [N]."""
        return {"force_bias_n": np.asarray(theta, dtype=float)}


@register
class ForceSensorCrosstalk(Family):
    """Cross-talk: each force axis reads a fraction of the other axes' forces."""

    name = "force_sensor_crosstalk"
    parameters = ("x_from_y_ratio", "x_from_z_ratio", "y_from_x_ratio", "y_from_z_ratio",
                  "z_from_x_ratio", "z_from_y_ratio")
    neutral = (0.0,) * 6
    bounds = ((-0.5,) * 6, (0.5,) * 6)
    scale = (0.01,) * 6
    description = "each force axis reads a fraction of the other axes"
    needs_forces = True
    acts_on = ("force",)
    PAIRS = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Force change M f with M zero on the diagonal."""
        f = ctx.pred["force"]
        out = np.zeros_like(f)
        for (i, j), m in zip(self.PAIRS, theta, strict=True):
            out[:, i] += m * f[:, j]
        return Delta(force=out)

    def to_instruments(self, theta: np.ndarray, ctx: Context) -> dict[str, np.ndarray] | None:
        """The F/T cross-talk ratios, in `twin.sim.instruments.CROSSTALK_PAIRS` order (this family's)."""
        return {"force_crosstalk": np.asarray(theta, dtype=float)}


@register
class ForceSensorGain(Family):
    """Each force axis reads a fraction more or less than the force (a sensor re-calibrated, or its calibration
    matrix for another range): the force stream alone changes, not the tool tip (a robot-side force scale moves
    both)."""

    name = "force_sensor_gain"
    parameters = ("gain_x_ratio", "gain_y_ratio", "gain_z_ratio")
    neutral = (1.0, 1.0, 1.0)
    bounds = ((0.2, 0.2, 0.2), (5.0, 5.0, 5.0))
    scale = (0.01, 0.01, 0.01)
    description = "the force sensor's calibration off by a factor per axis"
    needs_forces = True
    acts_on = ("force",)

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Force change (g - 1) f per axis."""
        return Delta(force=ctx.pred["force"] * (np.asarray(theta) - 1.0))

    def to_instruments(self, theta: np.ndarray, ctx: Context) -> dict[str, np.ndarray] | None:
        """The F/T gain per axis [-] (an increment multiplies the carried gain)."""
        return {"force_gain": np.asarray(theta, dtype=float)}


@register
class StreamTimeOffset(Family):
    """The force sensor's clock is offset from the tracker's and runs at a slightly different rate."""

    name = "stream_time_offset"
    parameters = ("offset_s", "skew_ratio")
    neutral = (0.0, 0.0)
    bounds = ((-2.0, -0.05), (2.0, 0.05))
    scale = (0.01, 1e-3)
    description = "force-sensor clock ahead of the tracker by an offset plus a rate error"
    needs_forces = True
    acts_on = ("force",)
    linear = False
    effect = "stream_time_offset"

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """A sample stamped t was measured at t - offset - skew (t - t0)."""
        assert ctx.run.forces is not None
        t = ctx.run.forces.t_s
        t0 = ctx.t_cmd[0]
        shifted = np.clip(t - theta[0] - theta[1] * (t - t0), ctx.t_cmd[0], ctx.t_cmd[-1])
        return Delta(force=ctx.sim.force_at(shifted, ctx.force_cmd) - ctx.pred["force"])

    def start(self, ctx: Context, residual: dict[str, np.ndarray]) -> np.ndarray:
        """The best offset of a coarse scan over the bounds (skew 0)."""
        taus = np.linspace(self.bounds[0][0], self.bounds[1][0], TIME_SCAN_POINTS)
        return np.array(self._best(ctx, residual["force"], [(float(t), 0.0) for t in taus], (0.0, 0.0)))

    def starts(self, ctx: Context, residual: dict[str, np.ndarray]) -> list[np.ndarray]:
        """`start`, and from it three scans: the skew with the mid-run shift held (over the bounds, then within
        one step of the best), then the offset finely. With the per-pass table field the force steps at each
        reversal, so the sum of squares jumps wherever a shifted sample crosses a step, and the least-squares
        refine keeps every sample on the side of the steps it starts on: a start at skew 0 can miss on a long run
        with a rate error, the scanned one can be drawn off by what the family does not model (the plant's
        transients at the reversals). Both are refined; the fit keeps the better."""
        target = residual["force"]
        assert ctx.run.forces is not None
        mid = 0.5 * (ctx.run.forces.t_s[0] + ctx.run.forces.t_s[-1]) - ctx.t_cmd[0]
        lo, hi = self.bounds
        coarse = self.start(ctx, residual)
        tau, skew = float(coarse[0]), 0.0
        shift = tau  # the mid-run shift, tau + skew * mid, held while the skew is scanned
        skews = np.linspace(lo[1], hi[1], SKEW_SCAN_POINTS)
        for _ in range(2):  # over the bounds, then within one step of the best: 2e-5 apart
            pairs = [(float(np.clip(shift - k * mid, lo[0], hi[0])), float(k)) for k in skews]
            tau, skew = self._best(ctx, target, pairs, (tau, skew))
            spacing = float(skews[1] - skews[0])
            skews = np.clip(skew + np.linspace(-spacing, spacing, SKEW_SCAN_POINTS), lo[1], hi[1])
        step = (hi[0] - lo[0]) / (TIME_SCAN_POINTS - 1)
        fine = tau + np.linspace(-step, step, TIME_SCAN_POINTS)
        tau, skew = self._best(ctx, target, [(float(np.clip(t, lo[0], hi[0])), skew) for t in fine], (tau, skew))
        scanned = np.array([tau, skew])
        return [coarse] if np.array_equal(scanned, coarse) else [coarse, scanned]

    def _best(
        self, ctx: Context, target: np.ndarray, pairs: list[tuple[float, float]], incumbent: tuple[float, float]
    ) -> tuple[float, float]:
        """The (offset, skew) of `pairs` with the least sum of squares against `target`, or `incumbent`."""
        def sse(pair: tuple[float, float]) -> float:
            force = self.delta(ctx, np.array(pair)).force
            assert force is not None
            return float(np.sum((target - force) ** 2))

        scores = [sse(p) for p in pairs]
        k = int(np.argmin(scores))
        return pairs[k] if scores[k] < sse(incumbent) else incumbent

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        """`stream_time_offset` [s] when the skew is not significant."""
        if not negligible(theta[1], covariance, 1):
            return None
        return float(theta[0])

    def to_instruments(self, theta: np.ndarray, ctx: Context) -> dict[str, np.ndarray] | None:
        """The F/T clock's offset [s] and rate error [-] (where the rate error is significant: `to_effect`)."""
        return {"force_clock_offset_s": np.array([theta[0]]), "force_clock_rate": np.array([theta[1]])}


def negligible(value: float, covariance: np.ndarray | None, index: int, *, sigmas: float = 3.0) -> bool:
    """Whether `value` is within `sigmas` standard errors of zero (True without a covariance)."""
    if covariance is None:
        return abs(value) < 1e-12
    sd = float(np.sqrt(max(covariance[index, index], 0.0)))
    return abs(value) <= sigmas * sd
