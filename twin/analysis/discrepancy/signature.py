"""The signature of what is left: the remainder described in words a process engineer reads.

For every stream axis whose remainder is above its noise (rms > SIGNATURE_RMS_FACTOR x sigma) the remainder is
tested for the structures a cell shows: a spectral peak (share of the variance within one bin of the peak), an
offset that flips with travel direction (correlation with the direction), a dependence on the forming force,
on the position along the stroke (distance to the stroke ends), a trend in time, and a transient at the
reversals (the share of the excess over noise within REVERSAL_WINDOW_S of a reversal, against the share of
time those windows take: a dynamic plant's or a real arm's ringing, a tool sticking). Structures whose
correlation (or peak share) reaches STRUCTURE_LEVEL are written out; an axis with none is called broadband.
Every axis also gets its rough spectrum: the shares of its power above the white-noise floor below, within and
above BANDS_HZ, and the band that holds most of it in its words.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from twin.analysis.discrepancy.context import Context

SIGNATURE_RMS_FACTOR = 1.3  # rms above this x the noise sigma: the axis carries something
STRUCTURE_LEVEL = 0.5  # |correlation| or spectral share from which a structure is named
REVERSAL_WINDOW_S = 0.15  # a sample this close to a reversal of the commanded path is "at a reversal" [s]
REVERSAL_TIME_SHARE_MAX = 0.3  # the windows must be a small part of the run for a concentration to mean anything
BANDS_HZ = (0.5, 5.0)  # slow (drifts, per-pass shapes), mid (reversals, oscillations), fast (chatter, sampling)
AXES = "xyz"
UNITS = {"position": ("mm", 1e3), "force": ("N", 1.0), "profile": ("mm", 1e3)}


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    denom = float(np.sqrt((a @ a) * (b @ b)))
    return float(a @ b / denom) if denom > 0 else 0.0


def _peak(values: np.ndarray, rate_hz: float) -> tuple[float, float, float]:
    """Frequency [Hz], amplitude and share of the variance of the strongest spectral peak (DC excluded)."""
    x = values - np.polyval(np.polyfit(np.arange(values.size), values, 1), np.arange(values.size))
    spec = np.fft.rfft(x * np.hanning(x.size))
    power = np.abs(spec) ** 2
    if power.size < 4 or power[1:].sum() <= 0:
        return 0.0, 0.0, 0.0
    k = 1 + int(np.argmax(power[1:]))
    share = float(power[max(k - 1, 1) : k + 2].sum() / power[1:].sum())
    amplitude = float(np.sqrt(2.0) * np.std(x) * np.sqrt(share))
    return float(k * rate_hz / x.size), amplitude, share


def _bands(values: np.ndarray, rate_hz: float, sigma: float) -> dict[str, float]:
    """Shares of the power above the white-noise floor below, within and above BANDS_HZ."""
    power = np.abs(np.fft.rfft(values - values.mean())) ** 2
    excess = np.clip(power - values.size * sigma**2, 0.0, None)
    freq = np.fft.rfftfreq(values.size, 1.0 / rate_hz)
    edges = (0.0, *BANDS_HZ, np.inf)
    names = (f"below {BANDS_HZ[0]:g} Hz", f"{BANDS_HZ[0]:g}-{BANDS_HZ[1]:g} Hz", f"above {BANDS_HZ[1]:g} Hz")
    total = float(excess.sum())
    return {name: float(excess[(freq >= lo) & (freq < hi)].sum() / total) if total > 0 else 0.0
            for name, lo, hi in zip(names, edges[:-1], edges[1:], strict=True)}


def _reversal_times(ctx: Context) -> np.ndarray:
    """Times of the commanded path's reversals [s] (direction changes of the replay's labels)."""
    sim = ctx.sim
    flips = np.flatnonzero(np.diff(sim.direction) != 0) + 1
    return np.asarray(sim.t_s[flips], dtype=float)


def _reversal_share(values: np.ndarray, t: np.ndarray, sigma: float, t_rev: np.ndarray) -> tuple[float, float, float]:
    """Share of the excess over noise within the reversal windows, their share of the samples, and the rms there."""
    if t_rev.size == 0:
        return 0.0, 0.0, 0.0
    near = np.min(np.abs(t[:, None] - t_rev[None, :]), axis=1) < REVERSAL_WINDOW_S
    excess = values**2 - sigma**2
    total = float(np.sum(excess))
    if total <= 0.0 or not near.any():
        return 0.0, float(near.mean()), 0.0
    share = min(1.0, float(np.sum(excess[near]) / total))  # the noise estimate may leave the rest a little below 0
    return share, float(near.mean()), float(np.sqrt(np.mean(values[near] ** 2)))


def _axis_signature(
    stream: str, axis: int, values: np.ndarray, t: np.ndarray, ctx: Context, sigma: float
) -> dict[str, Any]:
    unit, factor = UNITS[stream]
    sim = ctx.sim
    direction = np.interp(t, sim.t_s, sim.direction.astype(float))
    force = np.interp(t, sim.t_s, np.linalg.norm(sim.f_sheet_n, axis=1))
    x = np.interp(t, sim.t_s, sim.p_cmd_sheet_m[:, 0])
    near_end = np.exp(-(np.max(np.abs(x)) - np.abs(x)) / 0.005)
    rate = 1.0 / float(np.median(np.diff(t)))
    freq, amp, share = _peak(values, rate)
    out: dict[str, Any] = {
        "stream": stream, "axis": AXES[axis], "unit": unit,
        "rms": factor * float(np.sqrt(np.mean(values**2))), "noise": factor * sigma,
        "mean": factor * float(np.mean(values)),
        "peak_hz": freq, "peak_amplitude": factor * amp, "peak_share": share,
        "corr_direction": _corr(values, direction), "corr_force": _corr(values, force),
        "corr_stroke_end": _corr(values, near_end), "corr_time": _corr(values, t),
    }
    t_rev = _reversal_times(ctx)
    rev_share, rev_time, rev_rms = _reversal_share(values, t, sigma, t_rev)
    out.update(reversal_share=rev_share, reversal_time_share=rev_time, bands=_bands(values, rate, sigma))
    half_flip = 0.5 * (np.mean(values[direction > 0]) - np.mean(values[direction < 0])) if np.any(
        direction < 0) and np.any(direction > 0) else 0.0
    words = []
    if share >= STRUCTURE_LEVEL:
        words.append(f"a {freq:.2g} Hz oscillation of {factor * amp:.3g} {unit}")
    if abs(out["corr_direction"]) >= STRUCTURE_LEVEL:
        words.append(f"a +/-{factor * abs(half_flip):.3g} {unit} offset that flips with the travel direction")
    if abs(out["corr_force"]) >= STRUCTURE_LEVEL:
        words.append(f"a part that grows with the forming force (r = {out['corr_force']:.2f})")
    if abs(out["corr_stroke_end"]) >= STRUCTURE_LEVEL:
        words.append(f"a rise near the stroke ends (r = {out['corr_stroke_end']:.2f})")
    if abs(out["corr_time"]) >= STRUCTURE_LEVEL:
        slope = np.polyfit(t, values, 1)[0]
        words.append(f"a trend of {factor * slope:.3g} {unit}/s over the run")
    if rev_share >= STRUCTURE_LEVEL and rev_time <= REVERSAL_TIME_SHARE_MAX:
        words.append(
            f"a transient at the {t_rev.size} reversals, {factor * rev_rms:.3g} {unit} rms within "
            f"{REVERSAL_WINDOW_S:g} s of them ({rev_share:.0%} of the excess over noise in {rev_time:.0%} of the time)"
        )
    if not words:
        words.append(f"broadband, {out['rms']:.3g} {unit} rms against {factor * sigma:.3g} {unit} noise")
    band = max(out["bands"], key=out["bands"].get)
    if out["bands"][band] > 0:
        words.append(f"{out['bands'][band]:.0%} of its excess power {band}")
    out["words"] = f"{stream} {AXES[axis]}: " + "; ".join(words)
    return out


def describe_remainder(
    ctx: Context, remainder: dict[str, np.ndarray], sigma: dict[str, float], named: tuple[str, ...]
) -> dict[str, Any]:
    """Signature of the remainder (measured - twin - fitted families) per stream axis, and one sentence.

    Args:
        ctx: The linearised replay (times, direction, force, stroke position).
        remainder: Stream -> remainder in SI units (`position` (m, 3), `force` (k, 3), `profile` (p,)).
        sigma: Stream -> noise sigma per axis (SI).
        named: Families already named (for the sentence).

    Returns:
        `axes` (one entry per axis above noise, with its numbers and words) and `words`.
    """
    axes = []
    times = {"position": ctx.run.tracker.t_s}
    if ctx.run.forces is not None:
        times["force"] = ctx.run.forces.t_s
    for stream, t in times.items():
        values = remainder.get(stream)
        if values is None:
            continue
        for axis in range(3):
            column = values[:, axis]
            if np.sqrt(np.mean(column**2)) > SIGNATURE_RMS_FACTOR * sigma[stream]:
                axes.append(_axis_signature(stream, axis, column, t, ctx, sigma[stream]))
    if "profile" in remainder and np.sqrt(np.mean(remainder["profile"] ** 2)) > SIGNATURE_RMS_FACTOR * sigma[
            "profile"]:
        p = remainder["profile"]
        axes.append({"stream": "profile", "axis": "z", "unit": "mm", "rms": 1e3 * float(np.sqrt(np.mean(p**2))),
                     "noise": 1e3 * sigma["profile"], "mean": 1e3 * float(np.mean(p)),
                     "words": f"profile z: {1e3 * float(np.sqrt(np.mean(p**2))):.3g} mm rms along the groove"})
    tail = f"not explained by {', '.join(named)}" if named else "not explained by any family"
    if not axes:
        return {"axes": [], "words": "nothing left above the noise"}
    return {"axes": axes, "words": "; ".join(a["words"] for a in axes) + f" ({tail})"}
