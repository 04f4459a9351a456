"""The instruments' calibration a cell's runs show (the tracker's registration, the F/T sensor's bias), learned
with the cell and carried in its model file.

A laser tracker registered to the sheet with a small rotation and shift reads every tip turned and moved: a constant
offset, and a tilt that grows across the part. Neither is the robot's, and a cell learned without it leaves it in the
floor it records and in every later run's gap (where `discrepancy` would then name it on each run). It is fitted on
the learned twin's replay of the runs: the tracker residual r against the predicted reading p, r = w×p + s (w the
rotation vector about the sheet origin [rad], s the shift [m]; the forms of `twin.sim.instruments`), by linear least
squares over all runs together. With `lateness` (`learn --tracker-errors`) the reading's lateness dt joins them, r =
w×p + s − v·dt (v the reading's velocity), the rotation and the lateness within the robot learner's prior spreads, and
is carried as the tracker's clock. A lateness is the tracker's latency, or the robot's following error along the path:
both read the tip a velocity times a time behind. Carried as the tracker's, the second is not compensated, so it stays
opt-in (docs/learning.md). The F/T sensor's bias is the mean of the force residual over the runs (what a zeroing error
leaves; where the learned sheet leaves a mean error of its own, the bias takes it too, and the twin's sensor then
reads what the cell's does). They are added to the spec's instruments (`Instruments.plus`) and the residuals are those
of the spec's replay with its instruments, so learning twice from the same runs adds nothing the second time.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from twin.analysis.discrepancy.residuals import ResidualModel
from twin.analysis.learn.robot import gaussian_posterior
from twin.analysis.learn.tracker import TRACKER_SPREADS
from twin.runs.format import Run
from twin.sim.instruments import Instruments
from twin.sim.spec import TwinSpec

# the tracker's columns: its rotation w (3), shift s (3), lateness dt (1)
_ROTATION, _SHIFT, _LATE, _WIDTH = slice(0, 3), slice(3, 6), 6, 7


class InstrumentsFit(NamedTuple):
    """The instruments' calibration learned from runs.

    Attributes:
        instruments: The spec's instruments with what was found added.
        rotation_mrad: The tracker's rotation found, about the sheet origin [mrad], shape (3,).
        shift_mm: The tracker's shift found, sheet frame [mm], shape (3,).
        bias_n: The F/T bias found, sheet frame [N], shape (3,) (zero for runs without forces).
        late_s: How late the tracker reads the tip [s] (its clock's offset, `tracker_time_offset_s`).
    """

    instruments: Instruments
    rotation_mrad: np.ndarray
    shift_mm: np.ndarray
    bias_n: np.ndarray
    late_s: float = 0.0


def fit_instruments(runs: list[Run], spec: TwinSpec, lateness: bool = False) -> InstrumentsFit:
    """The tracker registration and the F/T bias the runs show against `spec`'s replay (module docstring);
    `lateness`: the tracker's lateness too (within the robot learner's prior spreads, as the rotation)."""
    rows, rhs, forces = [], [], []
    for run in runs:
        streams = ResidualModel(run, spec).streams(spec.effects)
        residual = streams["position"]
        if "force" in streams:
            forces.append(streams["force"])
        p = run.tracker.values - residual  # the twin's predicted reading
        block = np.zeros((len(p), 3, _WIDTH))
        block[:, 0, 1], block[:, 0, 2] = p[:, 2], -p[:, 1]  # w x p = -[p]x w
        block[:, 1, 0], block[:, 1, 2] = -p[:, 2], p[:, 0]
        block[:, 2, 0], block[:, 2, 1] = p[:, 1], -p[:, 0]
        block[:, :, _SHIFT] = np.eye(3)
        block[:, :, _LATE] = -np.gradient(p, run.tracker.t_s, axis=0)  # read dt late: p(t - dt) = p - v dt
        rows.append(block.reshape(-1, _WIDTH))
        rhs.append(residual.ravel())
    X, y = np.vstack(rows), np.concatenate(rhs)
    coef = _with_priors(X, y) if lateness else np.append(np.linalg.lstsq(X[:, :_LATE], y, rcond=None)[0], 0.0)
    rotation_mrad, shift_mm, late_s = 1e3 * coef[_ROTATION], 1e3 * coef[_SHIFT], float(coef[_LATE])
    bias_n = np.vstack(forces).mean(axis=0) if forces else np.zeros(3)
    instruments = spec.effects.instruments.plus(
        {"tracker_rotation_mrad": rotation_mrad, "tracker_shift_mm": shift_mm, "tracker_time_offset_s": [late_s],
         "force_bias_n": bias_n})
    return InstrumentsFit(instruments, rotation_mrad, shift_mm, bias_n, late_s)


def _with_priors(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The tracker's coefficients with the rotation and the lateness within `tracker.TRACKER_SPREADS`: on a cone at a
    steady speed a turn about z and a lateness move the reading alike (along the travel, by w r and v dt), and
    unweighted they trade without end."""
    spreads = np.asarray(TRACKER_SPREADS)
    precision = np.zeros(_WIDTH)
    precision[_ROTATION], precision[_LATE] = 1.0 / spreads[:3] ** 2, 1.0 / spreads[3] ** 2
    return gaussian_posterior(X, y, precision, np.zeros(_WIDTH))[0]
