"""The instruments' calibration a cell's runs show (the tracker's registration, the F/T sensor's bias), learned
with the cell and carried in its model file.

A laser tracker registered to the sheet with a small rotation and shift reads every tip turned and moved: a
constant offset, and a tilt that grows across the part. Neither is the robot's, and a cell learned without it
leaves it in the floor it records and in every later run's gap (where `discrepancy` would then name it on each
run). It is fitted on the learned twin's replay of the runs: the tracker residual r against the predicted
reading p, r = w x p + s (w the rotation vector about the sheet origin [rad], s the shift [m]; the forms of
`twin.sim.instruments`), by linear least squares over all runs together. The F/T sensor's bias is the mean of
the force residual over the runs (what a zeroing error leaves; where the learned sheet leaves a mean error of its
own, the bias takes it too, and the twin's sensor then reads what the cell's does). Both are added to the spec's
instruments (`Instruments.plus`) and the residuals are those of the spec's replay with its instruments, so
learning twice from the same runs adds nothing the second time.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from twin.analysis.discrepancy.residuals import ResidualModel
from twin.runs.format import Run
from twin.sim.instruments import Instruments
from twin.sim.spec import TwinSpec


class InstrumentsFit(NamedTuple):
    """The instruments' calibration learned from runs.

    Attributes:
        instruments: The spec's instruments with what was found added.
        rotation_mrad: The tracker's rotation found, about the sheet origin [mrad], shape (3,).
        shift_mm: The tracker's shift found, sheet frame [mm], shape (3,).
        bias_n: The F/T bias found, sheet frame [N], shape (3,) (zero for runs without forces).
    """

    instruments: Instruments
    rotation_mrad: np.ndarray
    shift_mm: np.ndarray
    bias_n: np.ndarray


def fit_instruments(runs: list[Run], spec: TwinSpec) -> InstrumentsFit:
    """The tracker registration and the F/T bias the runs show against `spec`'s replay (module docstring)."""
    rows, rhs, forces = [], [], []
    for run in runs:
        streams = ResidualModel(run, spec).streams(spec.effects)
        residual = streams["position"]
        if "force" in streams:
            forces.append(streams["force"])
        p = run.tracker.values - residual  # the twin's predicted reading
        block = np.zeros((len(p), 3, 6))
        block[:, 0, 1], block[:, 0, 2] = p[:, 2], -p[:, 1]  # w x p = -[p]x w
        block[:, 1, 0], block[:, 1, 2] = -p[:, 2], p[:, 0]
        block[:, 2, 0], block[:, 2, 1] = p[:, 1], -p[:, 0]
        block[:, :, 3:] = np.eye(3)
        rows.append(block.reshape(-1, 6))
        rhs.append(residual.ravel())
    coef, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)
    rotation_mrad, shift_mm = 1e3 * coef[:3], 1e3 * coef[3:]
    bias_n = np.vstack(forces).mean(axis=0) if forces else np.zeros(3)
    instruments = spec.effects.instruments.plus(
        {"tracker_rotation_mrad": rotation_mrad, "tracker_shift_mm": shift_mm, "force_bias_n": bias_n})
    return InstrumentsFit(instruments, rotation_mrad, shift_mm, bias_n)
