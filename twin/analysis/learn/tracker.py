"""A tracker's own errors beside the robot's deflection, as the robot learner fits them (`twin.analysis.learn.robot`).

A laser tracker reads the tool tip with errors of its own: a constant offset per axis (always fitted), its
registration's rotation about the sheet origin, and a reading late by a few milliseconds (its clock, or the robot's
following error along the path, which reads the same). Which of them a fit takes is a `TrackerErrors`; their columns
beside the joints' are `tracker_columns`, their prior spreads `TRACKER_SPREADS`.
"""

from __future__ import annotations

from enum import Enum

import numpy as np

#: Prior spreads of a run's tracker errors beside its offset (`tracker_columns`): its registration's rotation per
#: axis [rad] (a registration to the usual care is within ~1 mrad) and its lateness [s] (a tracker's latency is a
#: few milliseconds).
TRACKER_SPREADS = (2e-3, 2e-3, 2e-3, 0.01)
TRACKER_COLUMNS = len(TRACKER_SPREADS)


class TrackerErrors(Enum):
    """Which of a tracker's own errors the robot's fit takes beside its offset per axis (`learn`'s options)."""

    OFFSET = "offset"  #: the offset alone (the default)
    LATE = "late"  #: and its reading's lateness, the joints the runs cannot observe held (`learn --tracker-late`)
    TURNED = "turned"  #: and its rotation; unobserved joints kept with their prior's spread (`--tracker-errors`)


def tracker_columns(tip_m: np.ndarray, velocity_m_s: np.ndarray, turned: bool = True) -> np.ndarray:
    """(3m, 4) a tracker's own errors beside its offset, stacked as `robot.design`'s: its registration's rotation about
    the sheet origin (w x p, three columns [rad]; zeros unless `turned`) and a reading late by dt (-v dt [s]: the
    tracker's clock, or the servo's following error, which is the same), from the unloaded tip p [m] and its
    velocity v [m/s] at the tracker's times. A clock's rate (a lateness growing with t) is not among them: on a
    groove whose force grows pass by pass, -v t is nearly a wrist joint's column (its deflection under a drag that
    flips with the travel)."""
    p, v = tip_m, velocity_m_s
    cols = np.zeros((len(p), 3, TRACKER_COLUMNS))
    if turned:
        cols[:, 1, 0], cols[:, 2, 0] = -p[:, 2], p[:, 1]  # w_x: (0, -p_z, p_y)
        cols[:, 0, 1], cols[:, 2, 1] = p[:, 2], -p[:, 0]  # w_y: (p_z, 0, -p_x)
        cols[:, 0, 2], cols[:, 1, 2] = -p[:, 1], p[:, 0]  # w_z: (-p_y, p_x, 0)
    cols[:, :, 3] = -v
    return cols.transpose(1, 0, 2).reshape(-1, TRACKER_COLUMNS)
