"""The tracker's registration to the sheet frame: a small rigid error of the frame it reads in, taken off a run.

A laser tracker registered to the sheet with a small error reads every point through it:
reading = R(rotation) @ p_true + shift, sheet frame, the rotation (a rotation vector) about the SHEET ORIGIN.
Judged by such a tracker, a part can look better or worse than it is (the dynamic plant's default 0.2 mm /
1 mrad error ranked a compensation 31 % better by the tracker while the true part got 34 % worse: #47).

`take_off` maps a run's tracker back through a known registration; `fit_on_free_moves` finds one from the run
itself, on its free moves: the tracker samples where the tool is not loaded (|F| below `FREE_FORCE_N`), where the
robot's deflection is nil and tracker - command is the registration plus the unloaded robot's and the tracker's
own errors. Of those the largest is a following error that grows with speed (the servo's lag, the tracker's
latency and clock offset: 0.1-0.2 mm at 33 mm/s on the dynamic plant, of the registration's size), so the fit is

    tracker - command = rotation x command + shift + L @ v,

v the commanded velocity and L (3 x 3) [s] the speed-linear following error. What the free moves do not fix is
left out rather than guessed: a lag column whose velocity component stays near zero; a rotation component the
positions and the lag cannot tell apart (on a circle about the origin, as a cone's first turns, a lag along
the path looks exactly like a rotation: the rotation is then left at zero, the shift alone taken off). Where the
shift itself is not fixed (too few free samples, or free moves at one velocity only, where a lag and a shift
look alike: the groove's first pass without a backward free move), no registration is fitted (None).

The command is not what an unloaded arm reaches: its own sag and kinematic errors look like a registration too
(0.16 mm on a quasi-static lab cone, whose tracker is perfect), so `check` fits one here only when asked
(`--free-moves`); a learned cell's registration (`check --model`, `twin.analysis.learn.instruments`) is fitted
against the twin's replay, which holds the sag, and `TrackerRegistration.from_instruments` reads it.

Everything is SI inside (m, rad, s).
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np

from twin.base.signals import interp_rows
from twin.runs.format import Run, Stream
from twin.sim.instruments import Instruments
from twin.sim.instruments import rotation as rotation_matrix

__all__ = ["FREE_FORCE_N", "MIN_FREE_SAMPLES", "TrackerRegistration", "fit_on_free_moves", "take_off"]

#: A tracker sample is a free move where the force's norm is below this [N] (the F/T noise is ~5-15 N; at the
#: twin's ~1.5 µm/N compliance it deflects the tool by at most ~30 µm).
FREE_FORCE_N = 20.0
#: Fewer free samples than this fit nothing.
MIN_FREE_SAMPLES = 20
#: A parameter is fixed by the free moves when one unit of it (1 mrad, 1 mm of shift, 1 ms of lag), apart from
#: what the parameters fixed before it explain, moves their readings by at least this rms [m] (the tracker's
#: noise is ~20 µm per sample; with tens of samples such a unit is found to a fraction of itself).
FIXED_RMS_PER_UNIT_M = 10e-6
#: The shift must keep at least this fraction of its own effect once the lag is fitted (free moves in one
#: direction only leave none) [-].
SHIFT_FRACTION = 0.3
#: Free samples whose fit residual exceeds this many times the median residual are left out (an acceleration's
#: transient, a contact starting), and the fit repeated [-].
OUTLIER_FACTOR = 3.0


class TrackerRegistration(NamedTuple):
    """The tracker's registration error: reading = R(rotation_rad) @ p_true + shift_m (sheet frame).

    Attributes:
        rotation_rad: Rotation vector about the sheet origin [rad], shape (3,).
        shift_m: Translation [m], shape (3,).
        source: Where it comes from, in words ("the model file", "fitted on the run's free moves", ...).
        rms_m: Rms of the fit's residual over the samples it was fitted on [m], or None (not fitted).
    """

    rotation_rad: np.ndarray
    shift_m: np.ndarray
    source: str
    rms_m: float | None = None

    def summary(self) -> dict[str, object]:
        """JSON-ready: rotation [mrad], shift [mm], source (and the fit's rms [mm] when fitted)."""
        return {"rotation_mrad": (1e3 * np.asarray(self.rotation_rad)).tolist(),
                "shift_mm": (1e3 * np.asarray(self.shift_m)).tolist(), "source": self.source,
                "rms_mm": None if self.rms_m is None else 1e3 * self.rms_m}

    @classmethod
    def from_instruments(cls, instruments: Instruments, source: str) -> TrackerRegistration:
        """The registration a twin's instruments carry (`twin.sim.instruments`: the same form, mrad and mm)."""
        return cls(1e-3 * np.asarray(instruments.tracker_rotation_mrad), 1e-3 * np.asarray(instruments.tracker_shift_mm),
                   source)

    def text(self) -> str:
        """One line: that it was taken off, from where, and its size."""
        return (f"tracker registration taken off ({self.source}): rotation "
                f"{1e3 * float(np.linalg.norm(self.rotation_rad)):.2f} mrad, shift "
                f"{1e3 * float(np.linalg.norm(self.shift_m)):.2f} mm")


def take_off(run: Run, registration: TrackerRegistration) -> Run:
    """A copy of the run whose tracker is mapped back through the registration: p = R^T (reading - shift).

    Args:
        run: The run (not changed).
        registration: The tracker's registration error.

    Returns:
        The run with its tracker values in the true sheet frame [m]; every other stream as it was.
    """
    rotation = rotation_matrix(np.asarray(registration.rotation_rad, dtype=float))
    values = (run.tracker.values - np.asarray(registration.shift_m, dtype=float)) @ rotation
    return replace(run, tracker=Stream(run.tracker.t_s, values))


def _free_samples(run: Run) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """Tracker reading, commanded position and velocity [m, m/s] at the tracker's free samples, or None."""
    if run.forces is None:
        return None
    t_tr = run.tracker.t_s
    t_cmd, p_cmd = run.commanded.t_s, run.commanded.values
    inside = (t_tr >= max(run.forces.t_s[0], t_cmd[0])) & (t_tr <= min(run.forces.t_s[-1], t_cmd[-1]))
    t = t_tr[inside]
    if t.size < MIN_FREE_SAMPLES or t_cmd.size < 2:
        return None
    force = np.linalg.norm(interp_rows(t, run.forces.t_s, run.forces.values), axis=1)
    free = force < FREE_FORCE_N
    if np.sum(free) < MIN_FREE_SAMPLES:
        return None
    velocity = np.gradient(p_cmd, t_cmd, axis=0)
    return (run.tracker.values[inside][free], interp_rows(t[free], t_cmd, p_cmd),
            interp_rows(t[free], t_cmd, velocity), t[free])


def _columns(p: np.ndarray, v: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """The fit's columns, each the readings' change (3n,) [m] per unit: rotation per mrad, shift per mm, lag
    L[a, b] per ms."""
    eye = np.eye(3)
    rotation = [1e-3 * np.cross(eye[k], p).ravel() for k in range(3)]
    shift = [1e-3 * np.tile(eye[k], len(p)) for k in range(3)]
    lag = [1e-3 * (v[:, b][:, None] * eye[a][None, :]).ravel() for b in range(3) for a in range(3)]
    return rotation, shift, lag


def _apart(column: np.ndarray, basis: np.ndarray | None) -> np.ndarray:
    """`column` less its least-squares projection on the columns of `basis` (None: as it is)."""
    if basis is None or basis.shape[1] == 0:
        return column
    coef, *_ = np.linalg.lstsq(basis, column, rcond=None)
    return column - basis @ coef


def _rms(column: np.ndarray) -> float:
    return float(np.sqrt(np.sum(column**2) / (len(column) // 3)))


def _fixed_columns(p: np.ndarray, v: np.ndarray) -> tuple[list[int], list[int]] | None:
    """Which rotation components (0-2) and lag entries (0-8) the free moves fix beside the shift; None when
    they do not fix the shift."""
    rotation, shift, lag = _columns(p, v)
    keep_lag = [k for k, col in enumerate(lag) if _rms(col) >= FIXED_RMS_PER_UNIT_M]
    basis = np.column_stack([lag[k] for k in keep_lag]) if keep_lag else None
    for col in shift:  # each shift component must stay apart from the lag
        if _rms(_apart(col, basis)) < SHIFT_FRACTION * _rms(col):
            return None
    basis = np.column_stack([*shift, *(lag[k] for k in keep_lag)])
    keep_rotation: list[int] = []
    left = [0, 1, 2]
    while left:  # greedily, the rotation component best apart from what is kept
        strength = [_rms(_apart(rotation[k], basis)) for k in left]
        best = int(np.argmax(strength))
        if strength[best] < FIXED_RMS_PER_UNIT_M:
            break
        keep_rotation.append(left.pop(best))
        basis = np.column_stack([basis, rotation[keep_rotation[-1]]])
    return sorted(keep_rotation), keep_lag


def fit_on_free_moves(run: Run) -> TrackerRegistration | None:
    """The tracker's registration fitted on the run's free moves (module docstring).

    Linearised least squares of tracker - command = rotation x command + shift + L @ v over the tracker samples
    where |F| < `FREE_FORCE_N`, with the parameters the free moves do not fix left out (a rotation component left
    out is zero in the result, and its source says so), samples far off the fit dropped and the fit repeated.

    Args:
        run: A measured run with forces.

    Returns:
        The registration (source "fitted on the run's free moves", its rms the fit's), or None: no forces, fewer
        than `MIN_FREE_SAMPLES` free samples, or free moves that do not tell the shift from a lag.
    """
    free = _free_samples(run)
    if free is None:
        return None
    reading, p, v, _ = free
    fixed = _fixed_columns(p, v)
    if fixed is None:
        return None
    keep_rotation, keep_lag = fixed
    error = (reading - p).ravel()
    use = np.ones(len(p), dtype=bool)
    for attempt in range(4):
        rotation, shift, lag = _columns(p[use], v[use])
        design = np.column_stack([*shift, *(rotation[k] for k in keep_rotation), *(lag[k] for k in keep_lag)])
        target = (reading[use] - p[use]).ravel()
        coef, *_ = np.linalg.lstsq(design, target, rcond=None)
        rotation_all, shift_all, lag_all = _columns(p, v)
        full = np.column_stack([*shift_all, *(rotation_all[k] for k in keep_rotation),
                                *(lag_all[k] for k in keep_lag)])
        residual = np.linalg.norm((error - full @ coef).reshape(-1, 3), axis=1)
        keep = residual <= OUTLIER_FACTOR * float(np.median(residual))
        if attempt == 3 or np.array_equal(keep, use) or np.sum(keep) < MIN_FREE_SAMPLES:
            break
        use = keep
    omega = np.zeros(3)
    omega[keep_rotation] = 1e-3 * coef[3:3 + len(keep_rotation)]
    source = "fitted on the run's free moves"
    if len(keep_rotation) < 3:
        axes = "".join("xyz"[k] for k in range(3) if k not in keep_rotation)
        source += f"; its rotation about {axes} not fixed by them, left at 0"
    return TrackerRegistration(omega, 1e-3 * coef[:3], source, float(np.sqrt(np.mean(residual[use] ** 2))))
