"""The trajectory generator's timing: stop at every sharp corner, with a limited acceleration.

A robot program moves the tool with linear moves (VAL3 `movel`) through the path's points. Where two moves meet
at a sharp corner without a blend (the groove's reversals, a pyramid's corners), a CS8C-class controller
brings the tool to rest at the point and starts again, with the acceleration and deceleration the program sets;
it never reverses the velocity within one interpolation cycle. Here each commanded sample keeps its position
and the times are re-planned: the tool travels every segment at its programmed speed, except within
v^2 / (2 a) of a stop, where the speed is that of a constant deceleration to rest, sqrt(2 a d) at a distance d
from the stop (a trapezoidal profile along the path; the controller's jerk filter rounds its corners). Stops are
the first and last samples and every sample where the path turns by more than `STOP_ANGLE_DEG`.

The re-planned times are what the controller logs as its commanded trajectory, so a run from the dynamic plant
carries them in its commanded stream.
"""

from __future__ import annotations

import math

import numpy as np

from twin.errors import InputError

STOP_ANGLE_DEG = 30.0  # a turn sharper than this between two moves is a stop, not a blend [deg]


def stop_indices(p_m: np.ndarray, stop_angle_deg: float = STOP_ANGLE_DEG) -> np.ndarray:
    """Samples where the tool comes to rest: the ends and every sharp corner, sorted.

    Args:
        p_m: Commanded positions [m], shape (n, 3).
        stop_angle_deg: Turn angle above which a corner is a stop [deg].

    Returns:
        Sample indices, shape (k,), with 0 and n - 1.
    """
    seg = np.diff(p_m, axis=0)
    length = np.linalg.norm(seg, axis=1)
    moving = np.flatnonzero(length > 0.0)
    stops = [0, len(p_m) - 1]
    if moving.size >= 2:
        unit = seg[moving] / length[moving, None]
        cos_turn = np.einsum("ij,ij->i", unit[:-1], unit[1:])
        sharp = np.flatnonzero(cos_turn < math.cos(math.radians(stop_angle_deg)))
        stops.extend((moving[sharp + 1]).tolist())  # the corner is the sample where the next move starts
    return np.unique(np.asarray(stops, dtype=int))


def _time_from_rest(d_m: np.ndarray, v_mps: np.ndarray, a_mps2: float) -> np.ndarray:
    """Time to travel `d_m` from rest, accelerating at `a_mps2` up to `v_mps` [s]."""
    d_ramp = v_mps**2 / (2.0 * a_mps2)
    ramp = np.sqrt(2.0 * np.minimum(d_m, d_ramp) / a_mps2)
    return ramp + np.maximum(d_m - d_ramp, 0.0) / v_mps


def retime_with_stops(t_s: np.ndarray, p_m: np.ndarray, accel_mps2: float) -> np.ndarray:
    """Commanded times re-planned to stop at sharp corners with a limited acceleration.

    Args:
        t_s: Commanded times [s], shape (n,), increasing.
        p_m: Commanded positions [m], shape (n, 3).
        accel_mps2: Acceleration and deceleration along the path [m/s^2]; 0 keeps `t_s` (no stops).

    Returns:
        New times [s], shape (n,), from t_s[0]; a segment is never faster than programmed.

    Raises:
        InputError: Shapes differ or the times do not increase.
    """
    t = np.asarray(t_s, dtype=float)
    p = np.asarray(p_m, dtype=float)
    if p.shape != (len(t), 3) or np.any(np.diff(t) <= 0.0):
        raise InputError(f"expected increasing times (n,) and positions (n, 3); got {t.shape}, {p.shape}")
    if accel_mps2 <= 0.0 or len(t) < 2:
        return t.copy()
    ds = np.linalg.norm(np.diff(p, axis=0), axis=1)
    dt = np.diff(t)
    if not np.any(ds > 0.0):
        return t.copy()
    v = np.where(ds > 0.0, ds / dt, np.inf)  # programmed speed of each segment [m/s]
    s = np.concatenate([[0.0], np.cumsum(ds)])
    stops = stop_indices(p)
    stop_s = s[stops]
    # for each segment: the stop behind it and the stop ahead of it (along the arc)
    behind = stop_s[np.searchsorted(stop_s, s[:-1], side="right") - 1]
    ahead = stop_s[np.minimum(np.searchsorted(stop_s, s[1:], side="left"), len(stop_s) - 1)]
    v_fin = np.where(np.isfinite(v), v, 1.0)
    leaving = _time_from_rest(s[1:] - behind, v_fin, accel_mps2) - _time_from_rest(
        s[:-1] - behind, v_fin, accel_mps2
    )
    arriving = _time_from_rest(ahead - s[:-1], v_fin, accel_mps2) - _time_from_rest(
        ahead - s[1:], v_fin, accel_mps2
    )
    planned = np.where(ds > 0.0, np.maximum(leaving, arriving), dt)
    return t[0] + np.concatenate([[0.0], np.cumsum(np.maximum(planned, dt))])
