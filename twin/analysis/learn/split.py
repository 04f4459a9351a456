"""A run's replay gap split into the robot's part and the sheet's part.

The twin's robot driven by the run's own measured forces (its compliance J·K_q⁻¹·Jᵀ at the commanded pose, its
joint friction against the joints' motion and its servo's transient where it has one,
`twin.analysis.learn.robot`) leaves the robot's part of the gap:
what compliance, servo, backlash and friction the twin gets wrong. The difference between that tool tip and the
one the twin predicts with its own forces is the sheet's part: where the forces the twin assumes move the tool
elsewhere than the forces the cell measured.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from twin.analysis.learn.robot import RobotFit, predicted_deflection, rms_norm_mm, robot_rows
from twin.analysis.replay import ReplayResult
from twin.runs.format import Run
from twin.sim.quasi_static import Twin


class GapSplit(NamedTuple):
    """`split_gap`'s result [mm].

    Attributes:
        robot_rms_mm: RMS of the tracker minus the twin's robot driven by the measured forces.
        sheet_rms_mm: RMS of the twin's predicted tip minus that tip (what the twin's forces add).
    """

    robot_rms_mm: float
    sheet_rms_mm: float


def measured_force_tip(run: Run, twin: Twin) -> np.ndarray:
    """The twin's tool tip at the tracker's times driven by the run's measured forces, sheet frame [m]."""
    rows = robot_rows(run, twin)
    dof = len(twin.joint_stiffness)
    own = RobotFit(twin.joint_stiffness, np.zeros(dof), twin.joint_stiffness, twin.joint_friction,
                   np.ones(dof, dtype=bool), twin.spec.servo, twin.joint_friction, np.zeros(3), (), ())
    return run.tracker.values - rows.deflection_m + predicted_deflection(rows, own, np.zeros(3))


def split_gap(run: Run, twin: Twin, replayed: ReplayResult) -> GapSplit:
    """Split `replayed`'s position gap (module docstring); `twin` is the one that replayed the run."""
    tip = measured_force_tip(run, twin)
    return GapSplit(rms_norm_mm(run.tracker.values - tip), rms_norm_mm(replayed.tracker_pred_m - tip))
