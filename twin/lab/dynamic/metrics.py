"""What a corner does on the plant: the numbers a reviewer of a physical corner asks for, from the plant's truth.

A real cell at a corner stop turns its force over about one tool radius of travel, its deflection moves smoothly by
C dF, and the arm's first mode rings at tens of micrometres for a few tenths of a second; it does not lift off.
These measure that on a plant run's log (`DynamicLog`, the physical truth at every servo tick) and on a sheet law
driven along a rigid path (no robot at all):

* `rigid_force_jumps`: the in-plane force change per 0.1 mm of rigid travel, against the steady force;
* `corner_metrics`: the fast tip motion (the true tip minus its 50 ms moving mean, rms over the whole run), the
  ticks in contact lost while the command is 0.5 mm or more into the sheet, the largest |tip - command|, and per
  corner stop the in-plane force peak and the fast motion over the 0.3 s after it.

They read the plant's truth, which no twin code may: only the plant's own tests and experiments call them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from twin.lab.dynamic.sheet_laws import SheetLaw
from twin.lab.dynamic.trajectory import stop_indices

RIGID_STEP_M = 1e-4  # rigid travel between two force readings [m]
FAST_WINDOW_S = 0.05  # the moving mean the fast tip motion is taken about [s]
INTO_SHEET_M = 0.5e-3  # a tick counts for contact loss where the command is this far into the sheet [m]
AFTER_STOP_S = 0.3  # the window after a corner stop [s]


class RigidJumps(NamedTuple):
    """A sheet law along a rigid path, read every `RIGID_STEP_M`.

    Attributes:
        max_jump_n: Largest in-plane force change between two readings [N].
        p99_jump_n: Its 99th percentile [N].
        steady_n: The steady force: median |F| over the second half of the path [N].
        mean_f_n: Mean force, sheet frame [N], (3,).
    """

    max_jump_n: float
    p99_jump_n: float
    steady_n: float
    mean_f_n: np.ndarray

    @property
    def jump_over_steady(self) -> float:
        """The largest jump over the steady force [-]."""
        return self.max_jump_n / self.steady_n


def resample(p_m: np.ndarray, step_m: float = RIGID_STEP_M) -> np.ndarray:
    """A path [m], (n, 3), resampled every `step_m` of travel [m]."""
    p = np.asarray(p_m, dtype=float)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    s = np.arange(0.0, arc[-1], step_m)
    return np.column_stack([np.interp(s, arc, p[:, i]) for i in range(3)])


def rigid_forces(sheet: SheetLaw, p_m: np.ndarray) -> np.ndarray:
    """The sheet's force [N], (n, 3), along a rigid tip path [m], (n, 3): force, then advance, at each point."""
    p = np.asarray(p_m, dtype=float)
    sheet.start(p[0], 1.0 if p[min(1, len(p) - 1), 0] >= p[0, 0] else -1.0)
    out = np.zeros_like(p)
    for k, point in enumerate(p):
        out[k] = sheet.force(point)
        sheet.advance(point)
    return out


def rigid_force_jumps(sheet: SheetLaw, p_m: np.ndarray) -> RigidJumps:
    """In-plane force jumps of a (fresh) sheet along a rigid path [m], (n, 3), read every 0.1 mm."""
    f = rigid_forces(sheet, resample(p_m))
    jump = np.abs(np.diff(np.linalg.norm(f[:, :2], axis=1)))
    steady = float(np.median(np.linalg.norm(f[len(f) // 2 :], axis=1)))
    return RigidJumps(float(jump.max()), float(np.percentile(jump, 99)), steady, f.mean(axis=0))


class CornerMetrics(NamedTuple):
    """A plant run's corners (module docstring); lengths [mm], forces [N].

    Attributes:
        fast_rms_mm: The true tip minus its 50 ms moving mean, rms over the whole run.
        contact_lost_frac: Ticks without sheet force over the ticks with the command >= 0.5 mm into the sheet.
        contact_lost_episodes: Separate stretches of such ticks.
        max_error_mm: Largest |true tip - command|.
        rms_error_mm: RMS |true tip - command|.
        corner_peak_median_n: Median over the corner stops of the in-plane force peak in the 0.3 s after.
        corner_peak_max_n: The largest of those peaks.
        corner_fast_median_mm: Median over the corner stops of the fast tip motion (rms) in the 0.3 s after.
        corners: Corner stops counted.
    """

    fast_rms_mm: float
    contact_lost_frac: float
    contact_lost_episodes: int
    max_error_mm: float
    rms_error_mm: float
    corner_peak_median_n: float
    corner_peak_max_n: float
    corner_fast_median_mm: float
    corners: int


def corner_metrics(
    t_s: np.ndarray, p_tip_sheet_m: np.ndarray, f_sheet_n: np.ndarray, t_cmd_s: np.ndarray, p_cmd_sheet_m: np.ndarray
) -> CornerMetrics:
    """The corner numbers of a plant run.

    Args:
        t_s: Tick times [s], (m,).
        p_tip_sheet_m: True tool tip, sheet frame [m], (m, 3).
        f_sheet_n: Force of the sheet on the tool, sheet frame [N], (m, 3).
        t_cmd_s: The run's commanded times (the controller's, re-timed) [s], (n,).
        p_cmd_sheet_m: Commanded tip [m], (n, 3).
    """
    t, p, f = np.asarray(t_s), np.asarray(p_tip_sheet_m), np.asarray(f_sheet_n)
    p_cmd = np.column_stack([np.interp(t, t_cmd_s, p_cmd_sheet_m[:, i]) for i in range(3)])
    dt = float(t[1] - t[0])
    width = max(1, round(FAST_WINDOW_S / dt))
    kernel = np.ones(width) / width
    mean = np.column_stack([np.convolve(p[:, i], kernel, mode="same") for i in range(3)])
    edge = width // 2 + 1
    fast = np.linalg.norm(p - mean, axis=1)
    fast[:edge] = fast[-edge:] = np.nan  # the moving mean is not whole there
    into = p_cmd[:, 2] <= -INTO_SHEET_M
    lost = (np.linalg.norm(f, axis=1) == 0.0) & into
    error = np.linalg.norm(p - p_cmd, axis=1)
    in_plane = np.linalg.norm(f[:, :2], axis=1)
    peaks, rings = [], []
    after = round(AFTER_STOP_S / dt)
    for stop in stop_indices(np.asarray(p_cmd_sheet_m))[1:-1]:
        k0 = int(np.searchsorted(t, t_cmd_s[stop]))
        k1 = min(len(t), k0 + after)
        if k1 - k0 < 2:
            continue
        peaks.append(float(in_plane[k0:k1].max()))
        rings.append(float(np.sqrt(np.nanmean(fast[k0:k1] ** 2))))
    return CornerMetrics(
        fast_rms_mm=1e3 * float(np.sqrt(np.nanmean(fast**2))),
        contact_lost_frac=float(lost.sum() / max(int(into.sum()), 1)),
        contact_lost_episodes=int(np.sum(np.diff(lost.astype(int)) == 1)),
        max_error_mm=1e3 * float(error.max()),
        rms_error_mm=1e3 * float(np.sqrt(np.mean(error**2))),
        corner_peak_median_n=float(np.median(peaks)) if peaks else 0.0,
        corner_peak_max_n=float(np.max(peaks)) if peaks else 0.0,
        corner_fast_median_mm=1e3 * float(np.median(rings)) if rings else 0.0,
        corners=len(peaks),
    )
