"""The cause of a compensation gain, named from evidence: the forces the compensation used against the forces
measured (or the physical ones), and the symmetry recorded with its FE history.

A gain g scales the correction: g = 1 is right. Two things can make it: the forces (a compensation that used s
times the physical forces has g ≈ s, whatever its compliance) and the compliance (right forces, g = the ratio of
the compliance used to the robot's). The force scale s is the least-squares ratio of the forces used to the
forces measured, over the loaded samples (x and z). It names the cause only when it explains the gain; the
history's recorded symmetry then says why the forces were scaled. Without a record, the gain is reported and
its cause is unknown: no fixed band of gains stands in for evidence.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from twin.analysis.compensation_record import CompensationRecord
from twin.base.signals import interp_rows

#: A gain within 1 ± this is right.
GAIN_TOLERANCE = 0.02
#: The force scale explains the gain when they agree within this (absolute), or within this fraction of the gain.
EXPLAINS = 0.1
#: Forces under this fraction of the largest are left out of the force scale (the tool off the sheet).
LOADED_FRACTION = 0.1


class GainCause(NamedTuple):
    """A gain and what the evidence says of it.

    Attributes:
        gain: The compensation gain.
        force_scale: Forces used / forces measured (least squares, x and z), or None without a record.
        cause: `right`, `force_scale`, `half_history_as_full`, `compliance`, `both` or `unknown`.
        text: One line for the user.
    """

    gain: float
    force_scale: float | None
    cause: str
    text: str


def force_scale(record: CompensationRecord, t_s: np.ndarray, f_measured_n: np.ndarray) -> float:
    """Least-squares s in f_used ≈ s·f_measured over the loaded samples, x and z.

    Args:
        record: The compensation's record (its forces at its command times).
        t_s: Times of the measured forces [s], on the record's clock.
        f_measured_n: Measured (or physical) forces [N], shape (m, 3).
    """
    t = np.asarray(t_s, dtype=float)
    f = np.asarray(f_measured_n, dtype=float)[:, [0, 2]]
    inside = (t >= record.t_s[0]) & (t <= record.t_s[-1])
    used = interp_rows(t[inside], record.t_s, record.f_used_n)[:, [0, 2]]
    f = f[inside]
    norm = np.linalg.norm(f, axis=1)
    loaded = norm > LOADED_FRACTION * float(np.max(norm, initial=0.0))
    denominator = float(np.sum(f[loaded] ** 2))
    return float(np.sum(used[loaded] * f[loaded]) / denominator) if denominator > 0 else float("nan")


def name_cause(
    gain: float,
    record: CompensationRecord | None = None,
    t_s: np.ndarray | None = None,
    f_measured_n: np.ndarray | None = None,
) -> GainCause:
    """Name the cause of a gain from the compensation's record and the measured forces.

    Args:
        gain: The compensation gain.
        record: What the compensation used (None: unknown).
        t_s: Times of `f_measured_n` [s].
        f_measured_n: The forces the run measured (or the physical forces) [N], shape (m, 3).
    """
    kind = "under" if gain < 1 else "over"
    scale = None if record is None or t_s is None or f_measured_n is None else force_scale(record, t_s, f_measured_n)
    if scale is not None and not np.isfinite(scale):
        scale = None
    used = "" if scale is None else f"; it used a force scale of {scale:.2g} (its forces / the measured)"
    if abs(gain - 1.0) <= GAIN_TOLERANCE:
        return GainCause(gain, scale, "right", f"gain {gain:.3f} is within 1 +/- {GAIN_TOLERANCE}: the "
                         f"compensation corrects the deflection fully{used}")
    head = f"gain {gain:.3f}: the compensation {kind}-corrects by a factor {gain:.2f}"
    if scale is None or record is None:
        return GainCause(gain, scale, "unknown", f"{head}; the cause is unknown: the run records no compensation "
                         "(the forces it used, its FE history's symmetry) to compare with its measured forces")
    # right forces: a scale near 1, and nearer 1 than the gain (a scale of 0.91 under a gain of 0.907 is the cause,
    # not "right within 10 %")
    forces_right = abs(scale - 1.0) <= EXPLAINS and abs(scale - 1.0) <= abs(scale - gain)
    if abs(scale - gain) <= max(EXPLAINS, EXPLAINS * abs(gain)) and (record.symmetry_mismatch or not forces_right):
        if record.symmetry_mismatch:
            where = "" if record.history_file is None else f" ({record.history_file})"
            return GainCause(gain, scale, "half_history_as_full", (
                f"{head}{used}, which explains it: its FE history{where} has columns of a "
                f"{record.history_column_symmetry}-symmetric model and was loaded as {record.history_symmetry} "
                f"(declare symmetry='{record.history_column_symmetry}', sec. 2.2; the thesis's mistake, sec. 5.1)"))
        sym = "" if record.history_symmetry is None else (
            f"; its history's declared symmetry ({record.history_symmetry}) agrees with its column names")
        return GainCause(gain, scale, "force_scale", f"{head}{used}, which explains it: the forces it assumed "
                         f"are off{sym} (check the force model and the history's level)")
    if forces_right:  # a scale of 1 explains no gain: the forces are right, whatever the gain's distance to it
        return GainCause(gain, scale, "compliance", f"{head}{used}: its forces are right, so the compliance it "
                         f"used is off by about {gain:.2f} (check the stiffness)")
    return GainCause(gain, scale, "both", f"{head}{used}, which explains a gain of {scale:.2f}, not {gain:.2f}: "
                     "both its forces and its compliance are off")
