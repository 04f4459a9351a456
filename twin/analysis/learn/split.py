"""A run's replay gap split into the robot's part and the sheet's part.

The twin's robot driven by the run's own measured forces (its compliance J·K_q⁻¹·Jᵀ at the commanded pose, its
joint friction against the joints' motion and its servo's transient where it has one,
`twin.analysis.learn.robot`) leaves the robot's part of the gap:
what compliance, servo, backlash and friction the twin gets wrong. The difference between that tool tip and the
one the twin predicts with its own forces is the sheet's part: where the forces the twin assumes move the tool
elsewhere than the forces the cell measured.

Given the dynamic twin's servo, the same forces also drive the arm stepped in time (`twin.sim.dynamic.DynamicTwin`
with `forces`: its loop gives way to the force and its integral takes it up): the robot's part with the arm moving.
Where that is well below the quasi-static one, what the quasi-static robot misses is the arm's motion, not its
springs (docs/dynamic-twin.md, "The arm under the measured forces"; an F/T stream of tens of hertz folds the
force's fast content into the band the arm follows, and the moving arm then misses more).

Where the robot's part lies says what a compensation can do with it: its part above `FAST_HZ` is the arm moving
faster than a quasi-static robot follows, and its share of the mean square within `NEAR_STOP_S` of the
controller's stops (a pyramid's corners, a groove's reversals), against the share of the samples there, says
whether the stops hold it. docs/learning.md ("What the offline targets ask") has them on the plant's parts.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.signal import butter, filtfilt

from twin.analysis.learn.robot import RobotFit, predicted_deflection, rms_norm_mm, robot_rows
from twin.analysis.learn.servo_fit import prepare
from twin.analysis.replay import ReplayResult
from twin.base.signals import interp_rows
from twin.runs.format import Run
from twin.sim.dynamic import ServoModel
from twin.sim.quasi_static import Twin

#: Above this a gap is the arm moving faster than a quasi-static robot follows [Hz].
FAST_HZ = 0.5
#: Near a stop of the controller: within this of one [s].
NEAR_STOP_S = 0.3


class GapSplit(NamedTuple):
    """`split_gap`'s result [mm].

    Attributes:
        robot_rms_mm: RMS of the tracker minus the twin's robot driven by the measured forces.
        sheet_rms_mm: RMS of the twin's predicted tip minus that tip (what the twin's forces add).
        robot_fast_mm: The robot's part above `FAST_HZ`, rms (`fast_part_mm`; NaN for 15 samples or fewer).
        robot_near_stop: Its mean square's share within `NEAR_STOP_S` of a stop [-] (`near_stop_shares`).
        samples_near_stop: The tracker samples' share there [-].
        robot_moving_mm: RMS of the tracker minus the dynamic twin's arm driven by the measured forces under the
            servo given (`moving_arm_tip`); NaN without one.
    """

    robot_rms_mm: float
    sheet_rms_mm: float
    robot_fast_mm: float
    robot_near_stop: float
    samples_near_stop: float
    robot_moving_mm: float = float("nan")


def fast_part_mm(t_s: np.ndarray, gap_m: np.ndarray) -> float:
    """The rms length [mm] of a gap's part above `FAST_HZ`: a zero-phase second-order high-pass at the samples'
    median rate (a tracker's stream, near enough uniform).

    Args:
        t_s: Sample times [s], (m,), m > 15.
        gap_m: The gap at them [m], (m, 3).
    """
    rate_hz = 1.0 / float(np.median(np.diff(t_s)))
    b, a = butter(2, min(FAST_HZ / (0.5 * rate_hz), 0.99), "high")
    return rms_norm_mm(filtfilt(b, a, gap_m, axis=0))


def controller_stops(run: Run) -> np.ndarray:
    """The times [s] at which the run's command moves slower than half its median speed: the controller's stops
    (a sharp corner's, a reversal's)."""
    t_c = run.commanded.t_s
    speed = np.linalg.norm(np.gradient(run.commanded.values, t_c, axis=0), axis=1)
    return t_c[speed < 0.5 * np.median(speed)]


def near_stops(run: Run, t_s: np.ndarray) -> np.ndarray:
    """Which of the times `t_s` [s], (m,), lie within `NEAR_STOP_S` of one of the run's stops (`controller_stops`),
    (m,) bool: none for a run without stops."""
    stops = controller_stops(run)
    if not len(stops):
        return np.zeros(len(t_s), dtype=bool)
    index = np.searchsorted(stops, t_s)
    before, after = stops[np.clip(index - 1, 0, len(stops) - 1)], stops[np.clip(index, 0, len(stops) - 1)]
    return np.asarray(np.minimum(np.abs(t_s - before), np.abs(t_s - after)) < NEAR_STOP_S)


def near_stop_shares(run: Run, t_s: np.ndarray, gap_m: np.ndarray) -> tuple[float, float]:
    """(the share of a gap's mean square within `NEAR_STOP_S` of the run's stops, the samples' share there) [-];
    (0, 0) for a run without stops.

    Args:
        run: The run (its command's stops, `controller_stops`).
        t_s: Sample times [s], (m,).
        gap_m: The gap at them [m], (m, 3).
    """
    near = near_stops(run, t_s)
    if not near.any():
        return 0.0, 0.0
    square = np.sum(np.asarray(gap_m) ** 2, axis=1)
    total = float(np.sum(square))
    return (float(np.sum(square[near]) / total) if total > 0.0 else 0.0), float(np.mean(near))


def measured_force_deflection(run: Run, twin: Twin) -> np.ndarray:
    """The twin's deflection of the tool tip under the run's measured forces, along its command, at the tracker's
    times, sheet frame [m], (m, 3)."""
    rows = robot_rows(run, twin)
    dof = len(twin.joint_stiffness)
    own = RobotFit(twin.joint_stiffness, np.zeros(dof), twin.joint_stiffness, twin.joint_friction,
                   np.ones(dof, dtype=bool), twin.spec.servo, twin.joint_friction, np.zeros(3), (), ())
    return predicted_deflection(rows, own, np.zeros(3))


def measured_force_tip(run: Run, twin: Twin) -> np.ndarray:
    """The twin's tool tip at the tracker's times driven by the run's measured forces, sheet frame [m]: the command
    there (`robot_rows`' unloaded tip) plus `measured_force_deflection`."""
    unloaded = interp_rows(run.tracker.t_s, run.commanded.t_s, run.commanded.values)
    return unloaded + measured_force_deflection(run, twin)


def moving_arm_tip(run: Run, twin: Twin, servo: ServoModel) -> np.ndarray:
    """The dynamic twin's tool tip at the tracker's times, the arm stepped along the run's command under `servo` and
    driven by the run's measured forces as `measured_force_tip` takes them (`servo_fit.prepare`), sheet frame [m],
    (m, 3).

    Raises:
        InputError: A run without forces.csv.
    """
    moved = prepare(run, twin, measured_forces=True).simulate(servo)
    return interp_rows(run.tracker.t_s, moved.t_s, moved.p_sheet_m)


def split_gap(run: Run, twin: Twin, replayed: ReplayResult, servo: ServoModel | None = None) -> GapSplit:
    """Split `replayed`'s position gap (module docstring); `twin` is the one that replayed the run; with `servo`,
    the robot's part with the arm moving too."""
    tip = measured_force_tip(run, twin)
    robot = run.tracker.values - tip
    fast = fast_part_mm(run.tracker.t_s, robot) if len(robot) > 15 else float("nan")
    moving = float("nan") if servo is None else rms_norm_mm(run.tracker.values - moving_arm_tip(run, twin, servo))
    return GapSplit(rms_norm_mm(robot), rms_norm_mm(replayed.tracker_pred_m - tip), fast,
                    *near_stop_shares(run, run.tracker.t_s, robot), moving)
