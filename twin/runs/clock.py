"""Clock alignment of a measured stream with the commanded path: `t_shared = t_stream - offset`.

The offset is given, or found from an onset. A stream that starts recording before the robot moves shows a
kink where the motion (tracker) or the contact (force sensor) begins; the commanded path has the same kink
at a known time. The search cross-correlates the two around the kink: for each trial offset τ it fits
`m(t) = a + b·r(t - τ)` by least squares over a fixed window of stream samples (m: measured magnitude,
r: reference from the commanded path, zero before the path starts) and keeps the τ of the smallest residual,
refined by a parabola. Its standard uncertainty is `σ_τ = sqrt(σ² / c)`, with `σ²` the residual variance and
`c` the parabola's curvature of the sum of squares (Δ SSE = σ² at one standard deviation). The onset fit
inflates it for correlated residuals (model error: `(1 + ρ) / (1 - ρ)` with ρ the residuals' lag-1
autocorrelation). A vector stream (the tracker) is fitted per axis with one shared τ: the magnitude of a
noisy displacement is biased upwards near zero, which put the kink late by up to 15 σ (issue #29).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.errors import InputError
from twin.process.force.isf_params import IsfForceParams
from twin.process.force.sliding import RELEASE_LENGTH_M, sliding_direction

REFINE_MAX_WINDOWS = 6  # the reversal fit moves its window up to this many times to enclose the minimum
ONSET_NOISE_FACTOR = 6.0  # onset: first sample above baseline + 6 noise sigmas (and 2 % of the range)
ONSET_RANGE_FRACTION = 0.02
LEAD_IN_SAMPLES = 10  # the baseline is the median of the first samples: they must precede the onset
WINDOW_S = 1.0  # half-width of the window of stream samples around the coarse onset [s]


@dataclass(frozen=True)
class ClockFit:
    """A stream's clock offset.

    Attributes:
        offset_s: The stream clock's reading when the commanded path starts [s].
        sigma_s: Standard uncertainty of the offset [s] (0 for a given offset).
        method: `offset`, `force_onset` or `motion_onset`.
        refined_on: Features a second fit used (`reversals`), or "".
    """

    offset_s: float
    sigma_s: float
    method: str
    refined_on: str = ""


def _onset(t_s: np.ndarray, signal: np.ndarray) -> tuple[float, int]:
    """Coarse onset time and index of a signal that starts flat (baseline from the lead-in samples)."""
    steps = np.diff(signal[:LEAD_IN_SAMPLES])
    if np.all(steps > 0) or np.all(steps < 0):
        raise InputError(
            f"no quiet lead-in: the first {LEAD_IN_SAMPLES} samples already trend one way; the stream must start "
            "recording before the motion or contact, or give the clock offset explicitly"
        )
    baseline = float(np.median(signal[:LEAD_IN_SAMPLES]))
    noise = float(np.median(np.abs(steps))) / 0.954  # median |diff| of white noise = 0.954 sigma
    span = float(np.percentile(signal, 95)) - baseline
    threshold = baseline + max(ONSET_NOISE_FACTOR * noise, ONSET_RANGE_FRACTION * span)
    above = np.flatnonzero(signal > threshold)
    if span <= 0 or above.size == 0:
        raise InputError("no onset: the signal never rises above its lead-in level")
    k = int(above[0])
    if k < LEAD_IN_SAMPLES:
        raise InputError(
            f"no quiet lead-in: the signal is already above its onset threshold at sample {k + 1}; the stream "
            "must start recording before the motion or contact, or give the clock offset explicitly"
        )
    return float(t_s[k]), k


def step_of(t_s: np.ndarray) -> float:
    """Lag grid step: a tenth of the median sample interval [s]."""
    return float(np.median(np.diff(t_s))) / 10.0


def best_lag(
    t_s: np.ndarray, measured: np.ndarray, t_ref_s: np.ndarray, reference: np.ndarray, taus: np.ndarray
) -> tuple[float, float]:
    """Lag τ minimising the residual of `measured(t) ≈ a + b·reference(t - τ)`, and its uncertainty.

    Args:
        t_s: Sample times of `measured` [s].
        measured: Measured signal, shape (n,).
        t_ref_s: Times of the reference [s].
        reference: Reference signal, shape (m,), held constant outside its span.
        taus: Trial lags, evenly spaced [s].

    Returns:
        (τ [s], its standard uncertainty σ_τ [s]; inf when the residual has no curvature).
    """
    tau, sigma, _ = _lag_fit(t_s, measured, t_ref_s, reference, taus)
    return tau, sigma


def _residuals(
    t_s: np.ndarray, measured: np.ndarray, t_ref_s: np.ndarray, reference: np.ndarray, tau: float
) -> np.ndarray:
    """Residuals of `measured[:, j] ≈ a_j + b_j·reference[:, j](t - τ)` per column, shape (n, k)."""
    out = np.empty_like(measured)
    for j in range(measured.shape[1]):
        A = np.column_stack([np.ones(len(t_s)), np.interp(t_s - tau, t_ref_s, reference[:, j])])
        coef, *_ = np.linalg.lstsq(A, measured[:, j], rcond=None)
        out[:, j] = measured[:, j] - A @ coef
    return out


def _lag_fit(
    t_s: np.ndarray, measured: np.ndarray, t_ref_s: np.ndarray, reference: np.ndarray, taus: np.ndarray
) -> tuple[float, float, np.ndarray]:
    """`best_lag` for 1-D or (n, k) signals (one τ shared by the columns); also returns the residuals at τ."""
    m = measured.reshape(len(t_s), -1)
    r = reference.reshape(len(t_ref_s), -1)
    sse = np.array([float(np.sum(_residuals(t_s, m, t_ref_s, r, tau) ** 2)) for tau in taus])
    step = float(taus[1] - taus[0])
    k = int(np.clip(np.argmin(sse), 1, taus.size - 2))
    y0, y1, y2 = sse[k - 1], sse[k], sse[k + 1]
    curvature = (y0 - 2.0 * y1 + y2) / step**2 / 2.0  # SSE ≈ SSE* + c (τ - τ*)²
    shift = 0.0 if curvature <= 0 else float(np.clip((y0 - y2) / (4.0 * curvature * step), -step, step))
    variance = float(sse.min()) / max(m.size - 3 * m.shape[1], 1)
    sigma = float(np.sqrt(variance / curvature)) if curvature > 0 else float("inf")
    tau = float(taus[k] + shift)
    return tau, sigma, _residuals(t_s, m, t_ref_s, r, tau)


def honest_sigma(sigma_s: float, residuals: np.ndarray) -> float:
    """The onset fit's σ made to cover model error seen as correlated residuals [s].

    Args:
        sigma_s: Statistical σ of the lag fit (white residuals assumed) [s].
        residuals: The fit's residuals at the best lag, shape (n,) or (n, k).

    Returns:
        `sigma_s sqrt((1 + ρ) / (1 - ρ))`, ρ in [0, 0.95] the residuals' mean lag-1
        autocorrelation over the columns (an AR(1) effective sample count).
    """
    res = residuals.reshape(len(residuals), -1)
    num = float(np.sum(res[1:] * res[:-1]))
    den = float(np.sum(res * res))
    rho = float(np.clip(num / den, 0.0, 0.95)) if den > 0 else 0.0
    return float(sigma_s * np.sqrt((1.0 + rho) / (1.0 - rho)))


def sliding_reference(p_ref_m: np.ndarray) -> np.ndarray:
    """The x component of the tool's sliding direction along a commanded path (`twin.process.force.sliding`, with the
    ISF model's calibrated build-up length): +-1 on straight runs, through zero at each reversal and back to
    full over ~1 mm of travel, as the sheet's in-plane force does; shape (n,)."""
    turn = IsfForceParams().direction_length_m
    ref = np.zeros(len(p_ref_m))
    v = (0.0, 0.0)
    for i in range(1, len(p_ref_m)):
        vx, vy, _ = sliding_direction(
            v, p_ref_m[i, 0] - p_ref_m[i - 1, 0], p_ref_m[i, 1] - p_ref_m[i - 1, 1], turn, RELEASE_LENGTH_M
        )
        v = (vx, vy)
        ref[i] = vx
    if len(ref) > 1:
        ref[0] = ref[1]
    return ref


def refine_on_reversals(
    t_s: np.ndarray, f_sheet_n: np.ndarray, t_ref_s: np.ndarray, p_ref_m: np.ndarray, fit: ClockFit
) -> ClockFit:
    """Refine a force clock offset on the travel reversals, where the tangential force flips sign.

    The measured `fx/|f|` (in contact) is fitted to the x component of the sliding direction along the
    commanded path (`sliding_reference`: through zero at each reversal, then built up against the new travel
    over ~1 mm, as the sheet's in-plane force does) shifted by τ,
    within ±(4 σ + 20 half-samples) of the onset estimate, the window moved (up to REFINE_MAX_WINDOWS times)
    while the minimum sits on its edge. Each of the path's reversals is a sharp feature, so the
    refined offset is far more precise than the onset's. Without at least 2 reversals the fit is returned as is.
    Its uncertainty is statistical only: how the measured flip follows the commanded reversal is a model
    assumption (the tool also sticks while the robot unwinds; see docs/import-export.md for the bias measured
    on the virtual lab's runs).

    Args:
        t_s: Sensor times on its own clock [s].
        f_sheet_n: Contact force in the sheet frame, shape (n, 3) [N].
        t_ref_s: Commanded times [s].
        p_ref_m: Commanded positions in the sheet frame, shape (m, 3) [m].
        fit: The onset estimate.

    Returns:
        The refined fit (same method label), or `fit` when the path has fewer than 2 reversals.
    """
    direction = np.sign(np.diff(p_ref_m[:, 0]))  # direction of travel from each commanded sample to the next
    moving = direction != 0
    if np.count_nonzero(np.diff(direction[moving]) != 0) < 2 or not np.isfinite(fit.sigma_s):
        return fit
    reference = sliding_reference(p_ref_m)
    magnitude = np.linalg.norm(f_sheet_n, axis=1)
    contact = magnitude > 0.2 * np.percentile(magnitude, 95)
    step = step_of(t_s) / 2.0
    half = 4.0 * fit.sigma_s + 20.0 * step
    centre = fit.offset_s
    measured = f_sheet_n[contact, 0] / magnitude[contact]
    for _ in range(REFINE_MAX_WINDOWS):
        taus = centre + np.arange(-half, half, step)
        tau, sigma = best_lag(t_s[contact], measured, t_ref_s, reference, taus)
        if np.isfinite(sigma) and taus[1] < tau < taus[-2]:  # a minimum inside the window
            return ClockFit(tau, sigma, fit.method, "reversals")
        centre = tau  # the minimum lies at the window's edge: move the window there
    return fit


def onset_offset(
    t_stream_s: np.ndarray,
    measured: np.ndarray,
    t_ref_s: np.ndarray,
    reference: np.ndarray,
    *,
    max_offset_s: float,
    method: str,
) -> ClockFit:
    """Offset of a stream's clock found by cross-correlating its onset with the commanded path's.

    Args:
        t_stream_s: Stream sample times on its own clock, strictly increasing, shape (n,) [s].
        measured: Magnitude measured by the stream (|F| [N]), shape (n,), or its positions [m], shape (n, 3).
        t_ref_s: Commanded path times on the shared clock (from 0), shape (m,) [s].
        reference: The commanded counterpart: depth [m], zero at the start, shape (m,), or positions [m],
            shape (m, 3).
        max_offset_s: Largest acceptable |offset| [s].
        method: Label recorded in the result.

    Returns:
        The offset and its standard uncertainty (`honest_sigma`).

    Raises:
        InputError: No quiet lead-in, no onset, too few samples in the window, or |offset| > max_offset_s.
    """
    t = np.asarray(t_stream_s, dtype=float)
    m = np.asarray(measured, dtype=float)
    t_ref = np.asarray(t_ref_s, dtype=float)
    ref = np.asarray(reference, dtype=float)
    if t.size < 4 * LEAD_IN_SAMPLES:
        raise InputError(f"{t.size} stream samples; the onset search needs at least {4 * LEAD_IN_SAMPLES}")
    fitted = m
    if m.ndim == 2:  # a vector stream: onset on the displacement's magnitude, fit per axis
        fitted, m = m, np.linalg.norm(m - np.median(m[:LEAD_IN_SAMPLES], axis=0), axis=1)
        r_dist = np.linalg.norm(ref - ref[0], axis=1)
    else:
        r_dist = ref - ref[0]
    t_on, _ = _onset(t, m)
    rise = np.flatnonzero(r_dist > ONSET_RANGE_FRACTION * (np.percentile(r_dist, 95)))
    if rise.size == 0:
        raise InputError("the commanded reference never rises: no onset to align with")
    t_ref_on = float(t_ref[rise[0]])
    tau0 = t_on - t_ref_on
    window = (t >= t_on - WINDOW_S) & (t <= t_on + WINDOW_S)
    n = int(window.sum())
    if n < 8:
        raise InputError(f"{n} samples within {WINDOW_S} s of the onset; need at least 8")
    taus = tau0 + np.arange(-0.5, 0.5, step_of(t))
    tau, sigma, residuals = _lag_fit(t[window], fitted[window], t_ref, ref, taus)
    sigma = honest_sigma(sigma, residuals) if np.isfinite(sigma) else sigma
    if abs(tau) > max_offset_s:
        raise InputError(
            f"the onset gives a clock offset of {tau:.4g} s, more than max_offset_s {max_offset_s:g} s"
        )
    return ClockFit(tau, sigma, method)


def check_overlap(t_shared_s: np.ndarray, t_end_s: float, *, min_fraction: float = 0.5) -> None:
    """Raise InputError unless a stream on the shared clock covers `min_fraction` of the commanded path.

    Args:
        t_shared_s: Stream times on the shared clock [s].
        t_end_s: End of the commanded path [s] (it starts at 0).
        min_fraction: Smallest covered fraction of [0, t_end_s].
    """
    t = np.asarray(t_shared_s, dtype=float)
    covered = max(0.0, min(float(t[-1]), t_end_s) - max(float(t[0]), 0.0))
    if covered < min_fraction * t_end_s:
        raise InputError(
            f"the stream spans [{t[0]:.6g}, {t[-1]:.6g}] s on the shared clock but the commanded path spans "
            f"[0, {t_end_s:.6g}] s: they overlap for {covered:.3g} s, expected at least {min_fraction:.0%} "
            "(wrong clock offset or time unit?)"
        )
